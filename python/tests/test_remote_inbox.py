"""``quaketwin.fleet.watch`` over an inbox on an fsspec file system (issue 35:
"a new zip or folder in INBOX (or an fsspec prefix, polled) is processed once
it is complete … a partial upload is never processed").

The remote inbox is fsspec's in-memory file system (what an object store
looks like to fsspec: objects and prefixes, no rename); events are sample
records uploaded in pieces.  The library's watch processes the staged
copies; the dataset and the notifications are checked as for a local inbox.
"""

import json
import os
import pathlib
import tempfile
import unittest
import uuid

try:
    import fsspec
except ImportError:  # pragma: no cover - CI installs it
    fsspec = None

import quaketwin

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample-records"
PIPELINE = ROOT / "pipelines" / "ingest.toml"
ZIP_EVENT = SAMPLES / "synthetic-12storey-nsmp" / "NP.9999.zip"
FOLDER_EVENT = SAMPLES / "synthetic-2storey-yielding"


@unittest.skipIf(fsspec is None, "fsspec is not installed (CI installs it)")
class RemoteInboxTest(unittest.TestCase):
    def setUp(self):
        import quaketwin.fleet  # noqa: F401 - needs fsspec

        self.fleet = quaketwin.fleet
        self.fs = fsspec.filesystem("memory")
        self.root = f"/inbox-{uuid.uuid4().hex}"
        self.fs.mkdir(self.root)
        self.work = tempfile.TemporaryDirectory()
        self.out = os.path.join(self.work.name, "dataset")
        self.letters = os.path.join(self.work.name, "letters.jsonl")

    def tearDown(self):
        self.fs.rm(self.root, recursive=True)
        self.work.cleanup()

    def watch_once(self, **kw):
        return self.fleet.watch(
            f"memory://{self.root}",
            PIPELINE,
            self.out,
            notify=[f"cmd:cat >> {self.letters}"],
            no_dashboard=True,
            once=True,
            poll=0.05,
            **kw,
        )

    def letters_sent(self):
        if not os.path.exists(self.letters):
            return []
        text, letters, decoder, at = pathlib.Path(self.letters).read_text(), [], json.JSONDecoder(), 0
        while text[at:].strip():
            at += len(text[at:]) - len(text[at:].lstrip())
            letter, at = decoder.raw_decode(text, at)
            letters.append(letter)
        return letters

    def partitions(self):
        runs = pathlib.Path(self.out) / "runs"
        return sorted(str(p.relative_to(runs)) for p in runs.glob("structure=*/event=*"))

    def upload_folder(self, name, marker):
        for f in sorted(FOLDER_EVENT.iterdir()):
            self.fs.pipe(f"{self.root}/{name}/{f.name}", f.read_bytes())
        if marker:
            self.fs.pipe(f"{self.root}/{name}/.done", b"")

    def test_a_partial_upload_is_never_processed_and_each_event_once(self):
        data = ZIP_EVENT.read_bytes()
        # Half a zip, no marker: with require_done nothing is mirrored.
        self.fs.pipe(f"{self.root}/quake.zip", data[: len(data) // 2])
        s = self.watch_once(require_done=True)
        self.assertEqual(s["processed"], [])
        self.assertFalse(os.path.exists(os.path.join(self.out, "runs")))
        staging = self.out + ".inbox"
        self.assertEqual([n for n in os.listdir(staging) if not n.startswith(".")], [])
        # The whole zip and its marker, and a folder with a marker inside.
        self.fs.pipe(f"{self.root}/quake.zip", data)
        self.fs.pipe(f"{self.root}/quake.zip.done", b"")
        self.upload_folder("yielding", marker=True)
        s = self.watch_once(require_done=True)
        self.assertEqual(sorted(s["processed"]), ["quake.zip", "yielding"], s)
        self.assertEqual(s["failed"], [])
        self.assertEqual(len(self.partitions()), 2, self.partitions())
        letters = self.letters_sent()
        self.assertEqual(len(letters), 2)
        ids = {l["id"] for l in letters}
        # Nothing changed remotely: nothing mirrored or processed again.
        s = self.watch_once(require_done=True)
        self.assertEqual(s["processed"], [])
        self.assertEqual({l["id"] for l in self.letters_sent()}, ids)
        # The staged copies are byte for byte the uploads.
        self.assertEqual(pathlib.Path(staging, "quake.zip").read_bytes(), data)

    def test_unmarked_entries_are_complete_once_they_rest(self):
        self.upload_folder("yielding", marker=False)
        s = self.watch_once(settle=0.3)
        self.assertEqual(s["processed"], ["yielding"], s)
        # A changed remote entry is mirrored and processed again.
        self.fs.pipe(f"{self.root}/yielding/notes.txt", b"a note the site engineer added\n")
        s = self.watch_once(settle=0.3)
        self.assertEqual(s["processed"], ["yielding"], s)
        self.assertEqual(len(self.letters_sent()), 2)
        self.assertEqual(len(self.partitions()), 1)

    def test_a_truncated_zip_at_rest_is_mirrored_but_not_processed(self):
        data = ZIP_EVENT.read_bytes()
        self.fs.pipe(f"{self.root}/cut.zip", data[: len(data) // 3])
        s = self.watch_once(settle=0.2)
        self.assertEqual(s["processed"], [])
        self.assertEqual(s["incomplete"], ["cut.zip"], s)

    def test_bad_arguments(self):
        with self.assertRaises(TypeError):
            self.fleet.watch(f"memory://{self.root}", PIPELINE, self.out, once=True, setle=1)
        with self.assertRaises(ValueError):
            self.fleet.watch(f"memory://{self.root}", PIPELINE, "s3://bucket/dataset", once=True)
        with self.assertRaises(quaketwin.QuaketwinError):
            self.fleet.watch(f"memory://{self.root}", PIPELINE, self.out, once=True, poll=-1)


if __name__ == "__main__":
    unittest.main()
