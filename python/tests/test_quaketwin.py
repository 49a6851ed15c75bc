"""Tests of the Python package (docs/python.md): the bindings against the
command line's own outputs, and the Dask fleet (four sample events on a
LocalCluster of two workers, once undisturbed and once with a worker killed
mid-fleet) against the command line's many-event dataset, queried with
DuckDB.

Run: ``python3 -m unittest discover -s python/tests -v`` after installing
the wheel (``.ci/run`` does both); ``QUAKETWIN_BIN`` names the command-line
binary (default: ``$CARGO_TARGET_DIR/debug/quaketwin`` or ``target/debug``).
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import unittest.mock

import duckdb
import pyarrow as pa
import pyarrow.parquet as pq

import quaketwin
import quaketwin.fleet

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample-records"
PIPELINE = ROOT / "pipelines" / "post-earthquake.toml"
# Every sample folder is an event: most with an event.toml, the realistic
# building benchmarks as the networks publish them (a zip, no manifest).
EVENTS = sorted(p for p in SAMPLES.iterdir() if p.is_dir())
BIN = os.environ.get(
    "QUAKETWIN_BIN",
    str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "debug" / "quaketwin"),
)


def cli(*args):
    r = subprocess.run([BIN, "-q", *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"quaketwin {args}: {r.stderr}")
    return r.stdout


def modes_by_event(root):
    """(event, mode, frequency_hz) of every row of the modes dataset at root."""
    return duckdb.sql(
        f"select event, mode, frequency_hz from read_parquet('{root}/tables/modes/**/*.parquet', "
        "hive_partitioning=true) order by event, mode"
    ).fetchall()


class Bindings(unittest.TestCase):
    def test_inspect_and_read_event_describe_the_same_records(self):
        event = SAMPLES / "synthetic-4storey-quake"
        inventory = quaketwin.inspect(event)
        table = quaketwin.read_event(event)
        self.assertIsInstance(table, pa.Table)
        npts = {c["id"]: c["npts"] for c in inventory["channels"]}
        self.assertEqual(table.num_rows, sum(npts.values()))
        counts = table.group_by("channel_id").aggregate([("sample", "count")]).to_pylist()
        self.assertEqual({r["channel_id"]: r["sample_count"] for r in counts}, npts)
        channels = json.loads(table.schema.metadata[b"quaketwin.channels"])
        self.assertEqual(sorted(c["id"] for c in channels), sorted(npts))

    def test_modal_in_memory_reproduces_the_command_line(self):
        # The command line's modal stage identifies the conditioned samples;
        # the same table handed over in memory with the same (default)
        # settings gives the same modes, bit for bit.
        with tempfile.TemporaryDirectory() as out:
            cli("modal", SAMPLES / "synthetic-4storey-ambient", "--out", out)
            samples = pq.read_table(pathlib.Path(out) / "samples/samples.parquet")
            modes, stabilization = quaketwin.modal(samples)
            expected = pq.read_table(pathlib.Path(out) / "modes/modes.parquet")
            self.assertGreater(expected.num_rows, 0)
            self.assertEqual(
                modes.column("frequency_hz").to_pylist(),
                expected.column("frequency_hz").to_pylist(),
            )
            self.assertEqual(modes.schema.metadata[b"quaketwin.schema"], b"modes")
            self.assertGreater(stabilization.num_rows, modes.num_rows)

    def test_errors_are_exceptions_with_the_library_message(self):
        missing = SAMPLES / "no-such-event"
        with self.assertRaises(quaketwin.QuaketwinError) as caught:
            quaketwin.read_event(missing)
        self.assertIn("no-such-event", str(caught.exception))
        table = quaketwin.read_event(SAMPLES / "synthetic-4storey-quake")
        with self.assertRaises(quaketwin.UsageError) as caught:
            quaketwin.modal(table, {"band_hz": [5.0, 1.0]})
        self.assertIn("band_hz", str(caught.exception))

    def test_a_fifo_as_reference_raises_at_once(self):
        # Issue 33: a FIFO named as an input is refused before it is opened
        # (it blocked forever); the message names it.
        with tempfile.TemporaryDirectory() as work:
            fifo = pathlib.Path(work) / "modes.fifo"
            os.mkfifo(fifo)
            start = time.monotonic()
            with self.assertRaises(quaketwin.UsageError) as caught:
                quaketwin.run(PIPELINE, SAMPLES / "synthetic-4storey-quake",
                              pathlib.Path(work) / "out", reference=fifo)
            self.assertLess(time.monotonic() - start, 10.0)
            self.assertIn(str(fifo), str(caught.exception))
            self.assertIn("FIFO", str(caught.exception))

    def test_run_returns_the_command_line_summary(self):
        with tempfile.TemporaryDirectory() as out:
            summary = quaketwin.run(PIPELINE, SAMPLES / "synthetic-2storey-yielding", out)
            self.assertTrue(summary["ok"])
            self.assertEqual(summary["assessment"]["rating"], "YELLOW")
            self.assertEqual(summary["screening"]["rating"], "red")
            self.assertTrue((pathlib.Path(out) / "report.html").is_file())


class Fleet(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.reference = tempfile.TemporaryDirectory()
        cli("run", PIPELINE, SAMPLES, "--out", cls.reference.name)
        cls.expected = modes_by_event(cls.reference.name)
        assert {e for e, _, _ in cls.expected} >= {"synthetic-4storey-quake"}

    @classmethod
    def tearDownClass(cls):
        cls.reference.cleanup()

    def cluster(self):
        from dask.distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        return cluster, Client(cluster)

    def test_fleet_on_two_workers_equals_the_command_line_and_reruns_skip(self):
        cluster, client = self.cluster()
        with cluster, client, tempfile.TemporaryDirectory() as out:
            runs = quaketwin.fleet.run(PIPELINE, EVENTS, out, client=client, progress=False)
            self.assertEqual(runs.column("status").to_pylist(), ["ok"] * len(EVENTS), runs.to_pylist())
            self.assertEqual(modes_by_event(out), self.expected)
            # The table tree holds one part file per table and event, nothing else.
            parts = list(pathlib.Path(out).glob("tables/*/structure=*/event=*/*"))
            self.assertTrue(parts)
            for part in parts:
                self.assertEqual(part.name, "part-0.parquet", part)
            again = quaketwin.fleet.run(PIPELINE, EVENTS, out, client=client, progress=False)
            self.assertEqual(again.column("status").to_pylist(), ["skipped"] * len(EVENTS))
            self.assertEqual(
                pq.read_table(pathlib.Path(out) / "fleet_runs" / "part-0.parquet").num_rows,
                len(EVENTS),
            )

    def test_the_command_line_entry_runs_the_fleet(self):
        with tempfile.TemporaryDirectory() as out:
            event = SAMPLES / "synthetic-2storey-yielding"
            r = subprocess.run(
                [BIN, "fleet", PIPELINE, event, "--out", out, "--quiet"],
                capture_output=True,
                text=True,
                env=dict(os.environ, QUAKETWIN_PYTHON=sys.executable),
            )
            self.assertEqual(r.returncode, 0, r.stderr)
            runs = pq.read_table(pathlib.Path(out) / "fleet_runs" / "part-0.parquet").to_pylist()
            self.assertEqual([(x["event"], x["status"]) for x in runs], [(str(event), "ok")])
            modes = [row for row in modes_by_event(out)]
            self.assertEqual(modes, [m for m in self.expected if m[0] == event.name])

    def test_a_worker_killed_mid_fleet_leaves_every_event_exactly_once(self):
        cluster, client = self.cluster()
        with cluster, client, tempfile.TemporaryDirectory() as out:
            result = {}
            runner = threading.Thread(
                target=lambda: result.update(
                    runs=quaketwin.fleet.run(PIPELINE, EVENTS, out, client=client, progress=False)
                )
            )
            runner.start()
            killed = None
            deadline = time.time() + 120
            while killed is None and time.time() < deadline and runner.is_alive():
                busy = [w for w, tasks in client.processing().items() if tasks]
                if busy:
                    killed = busy[0]
                    try:
                        client.run(os._exit, 1, workers=[killed])
                    except Exception:
                        pass  # the worker died before answering: that is the point
                else:
                    time.sleep(0.05)
            runner.join(timeout=600)
            self.assertIsNotNone(killed, "no worker was busy to kill")
            self.assertFalse(runner.is_alive(), "the fleet did not finish")
            runs = result["runs"]
            self.assertEqual(runs.column("status").to_pylist(), ["ok"] * len(EVENTS), runs.to_pylist())
            self.assertEqual(modes_by_event(out), self.expected)
            # The killed task's run directory (inside the dataset, so that
            # publishing is a rename) is gone with the fleet's work folder,
            # and no temporary file is left anywhere in the dataset.
            self.assertFalse((pathlib.Path(out) / "_fleet" / "work").exists())
            self.assertEqual([p for p in pathlib.Path(out).rglob("*") if p.name.endswith(".tmp")], [])

    def test_the_fleets_own_cluster_is_sized_to_the_cores_without_the_trim_threshold(self):
        # Issue 33: Dask's MALLOC_TRIM_THRESHOLD_=65536 made glibc unmap and
        # map again every freed block above 64 KiB (ten times the page
        # faults: +20 % wall time), and two workers each with rayon on every
        # core oversubscribed the cores.
        from dask.distributed import Client

        with unittest.mock.patch.dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536"):  # as an earlier cluster leaves it
            cluster = quaketwin.fleet.local_cluster()
        with cluster, Client(cluster) as client:
            client.wait_for_workers(len(cluster.workers))
            env = client.run(lambda: {k: os.environ.get(k) for k in ("MALLOC_TRIM_THRESHOLD_", "RAYON_NUM_THREADS")})
            self.assertEqual(len(env), os.cpu_count())
            cores = os.cpu_count()
            for e in env.values():
                self.assertIsNone(e["MALLOC_TRIM_THRESHOLD_"])
                self.assertEqual(e["RAYON_NUM_THREADS"], str(max(1, cores // len(env))))
            profiling = client.run(lambda: __import__("dask").config.get("distributed.worker.profile.enabled"))
            self.assertEqual(set(profiling.values()), {False})
            with tempfile.TemporaryDirectory() as out:
                event = SAMPLES / "synthetic-2storey-yielding"
                runs = quaketwin.fleet.run(PIPELINE, [event], out, client=client, progress=False)
                self.assertEqual(runs.column("status").to_pylist(), ["ok"])
                self.assertEqual(modes_by_event(out), [m for m in self.expected if m[0] == event.name])
                self.assertFalse((pathlib.Path(out) / "_fleet" / "work").exists())


class TrackTest(unittest.TestCase):
    """``quaketwin.track`` and ``quaketwin.fleet.track`` on a small synthetic
    archive (two hours, 4 channels at 20 Hz, 20-minute windows) against the
    command line's ``track`` on the same archive."""

    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.TemporaryDirectory(prefix="quaketwin-track-")
        cls.arch = pathlib.Path(cls.work.name) / "arch"
        cli("synth-archive", "--out", cls.arch, "--days", "2", "--day-length", "1h",
            "--channels", "4", "--rate", "20")
        cls.flags = dict(stationxml=cls.arch / "station.xml", window="20m", training="1h",
                         cycle="1h", end="2026-01-01T02:00:00Z")
        cls.cli_out = pathlib.Path(cls.work.name) / "cli"
        cli("track", cls.arch / "sds", "--out", cls.cli_out, "--stationxml", cls.arch / "station.xml",
            "--window", "20m", "--training", "1h", "--cycle", "1h", "--end", "2026-01-01T02:00:00Z")

    @classmethod
    def tearDownClass(cls):
        cls.work.cleanup()

    def _same_table(self, out):
        mine = pq.read_table(out / "modal_tracking/modal_tracking.parquet")
        theirs = pq.read_table(self.cli_out / "modal_tracking/modal_tracking.parquet")
        self.assertEqual(mine.num_rows, theirs.num_rows)
        self.assertGreater(mine.num_rows, 0)
        for name in ("window_start", "mode", "frequency_hz", "damping_ratio", "flagged"):
            self.assertEqual(mine.column(name).to_pylist(), theirs.column(name).to_pylist(), name)

    def test_track_in_process_equals_the_command_line(self):
        out = pathlib.Path(self.work.name) / "py"
        s = quaketwin.track(self.arch / "sds", out, **self.flags)
        self.assertEqual(s["windows"], 6)
        self._same_table(out)

    def test_fleet_track_maps_windows_over_dask(self):
        out = pathlib.Path(self.work.name) / "fleet"
        s = quaketwin.fleet.track(self.arch / "sds", out, **self.flags)
        self.assertEqual(s["identified_windows"], 6)
        self._same_table(out)
        self.assertTrue((out / "tracking.html").is_file())

    def test_a_fifo_as_stationxml_raises_at_once(self):
        # Issue 33: refused before it is opened (it blocked forever).
        fifo = pathlib.Path(self.work.name) / "station.fifo"
        os.mkfifo(fifo)
        start = time.monotonic()
        with self.assertRaises(quaketwin.QuaketwinError) as caught:
            quaketwin.track(self.arch / "sds", pathlib.Path(self.work.name) / "fifo-out",
                            **dict(self.flags, stationxml=fifo))
        self.assertLess(time.monotonic() - start, 10.0)
        self.assertIn(str(fifo), str(caught.exception))
        self.assertIn("FIFO", str(caught.exception))

    def test_bad_options_raise_usage_errors(self):
        with self.assertRaises(quaketwin.UsageError):
            quaketwin.track(self.arch / "sds", pathlib.Path(self.work.name) / "bad", window="0h")


class ParameterBounds(unittest.TestCase):
    """The values that once killed the interpreter (SIGABRT) or raised
    ``pyo3_runtime.PanicException`` raise ``UsageError`` (a
    ``QuaketwinError``) naming the key, quickly (issue 33)."""

    def assertRefused(self, call, *names):
        t0 = time.monotonic()
        with self.assertRaises(quaketwin.UsageError) as caught:
            call()
        self.assertIsInstance(caught.exception, quaketwin.QuaketwinError)
        for name in names:
            self.assertIn(name, str(caught.exception))
        self.assertLess(time.monotonic() - t0, 30.0)

    def test_a_panic_is_a_quaketwin_error_naming_the_function(self):
        from quaketwin import _native

        with self.assertRaises(quaketwin.QuaketwinError) as caught:
            _native._panic_probe()
        self.assertNotIsInstance(caught.exception, quaketwin.UsageError)
        self.assertIn("internal error in quaketwin._panic_probe", str(caught.exception))
        self.assertIn("deliberate panic", str(caught.exception))
        # ... and `except Exception` catches it (PanicException derives from BaseException).
        try:
            _native._panic_probe()
        except Exception:
            pass

    def test_modal_orders_and_lists_are_bounded(self):
        table = quaketwin.read_event(SAMPLES / "synthetic-4storey-ambient")
        for settings, key in [
            ({"orders": [2, 2**63 - 1, 2]}, "orders"),
            ({"orders": [2, 2**64, 2]}, "modal settings"),
            ({"block_rows": 10**12}, "block_rows"),
            ({"psd_segment": 10**12}, "psd_segment"),
            ({"manual_frequencies_hz": [1.0] * 257}, "manual_frequencies_hz"),
        ]:
            self.assertRefused(lambda: quaketwin.modal(table, settings), key)

    def _pipeline(self, work, kind, params):
        text = (
            '[pipeline]\nname = "bounds"\n[[stage]]\nname = "ingest"\nkind = "ingest"\n'
            '[[stage]]\nname = "condition"\nkind = "condition"\ninputs = ["ingest"]\n'
            f'[[stage]]\nname = "{kind}"\nkind = "{kind}"\ninputs = ["condition"]\n'
            f"[stage.params]\n{params}\n"
        )
        path = pathlib.Path(work) / f"{kind}.toml"
        path.write_text(text)
        return path

    def test_pipeline_params_are_bounded(self):
        event = SAMPLES / "synthetic-2storey-yielding"
        periods = ", ".join(["0.5"] * 1001)
        with tempfile.TemporaryDirectory() as work:
            for kind, params, key in [
                ("hysteresis", "exponent_max = 1e300", "exponent_max"),
                ("hysteresis", "exponent_max = 1e5", "exponent_max"),
                ("modal", "orders = [2, 9223372036854775807, 2]", "orders"),
                ("metrics", f"periods_s = [{periods}]", "periods_s"),
            ]:
                pipeline = self._pipeline(work, kind, params)
                out = pathlib.Path(work) / "out"
                self.assertRefused(lambda: quaketwin.run(pipeline, event, out), key)

    def test_track_window_counts_are_bounded(self):
        with tempfile.TemporaryDirectory() as work:
            archive = pathlib.Path(work) / "sds"
            archive.mkdir()
            span = {"start": "2026-01-01T00:00:00Z", "end": "2027-01-01T00:00:00Z"}
            out = pathlib.Path(work) / "out"
            self.assertRefused(
                lambda: quaketwin.track(archive, out, window="60s", step="0.001s", **span),
                "--step",
            )
            self.assertRefused(lambda: quaketwin.track(archive, out, window="100d", **span), "--window")


if __name__ == "__main__":
    unittest.main()
