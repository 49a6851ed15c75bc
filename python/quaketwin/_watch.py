"""The implementation of ``quaketwin.fleet.watch``: ``quaketwin watch`` over
an inbox on any fsspec file system (an object-store prefix, polled).

The command line's watch reads a local folder.  For a remote inbox this
module mirrors each *complete* remote entry into a local staging inbox and
lets the library's watch (the same code as ``quaketwin watch``) process it:

- a remote entry (``NAME.zip`` or a prefix ``NAME/`` directly under the inbox)
  is complete when a marker says so (``NAME.done`` beside it, ``NAME/.done``
  inside) or, unless ``require_done``, when its listing (names, sizes, ETags
  or modification times) is unchanged for ``settle`` seconds — a partial
  upload is never mirrored;
- it is downloaded under a hidden temporary name, moved into place, and only
  then marked complete locally (``NAME.done``, holding the remote listing's
  digest): the library's watch, run with ``require_done``, never sees a
  half-downloaded entry;
- an entry whose remote listing changes is mirrored again (the library's
  watch then processes the new version, as it would a changed local entry);
- the staging inbox is a folder of its own (default: beside the dataset,
  ``DATASET.inbox``): the inbox and the outputs never contain one another.

Restart-safe as the library's watch is: the staged markers carry what was
mirrored, the dataset's ``_watch/`` journal what was processed and notified.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import sys
import threading
import time
import uuid
from datetime import datetime, timezone
from typing import Any, Dict, Iterable, Optional, Tuple

from . import _native

# Names an uploader uses while a transfer runs (the library's watch skips
# the same ones).
_PARTIAL_SUFFIXES = (".partial", ".tmp", ".crdownload", ".filepart")
_DONE = ".done"


def _log(level: str, msg: str, **fields: Any) -> None:
    """One JSON object per line on stderr, keys sorted (the library's log)."""
    line = dict(fields, ts=datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ"), level=level, msg=msg)
    sys.stderr.write(json.dumps(line, sort_keys=True, default=str) + "\n")
    sys.stderr.flush()


def _base(path: str) -> str:
    return path.rstrip("/").rsplit("/", 1)[-1]


def _stamp(info: Dict[str, Any]) -> str:
    """What changes when an object is rewritten: its ETag, else its time."""
    for key in ("ETag", "etag", "md5Hash", "mtime", "LastModified", "last_modified", "updated", "created"):
        if info.get(key) is not None:
            return str(info[key])
    return ""


class _Remote:
    """The remote inbox: its entries, their listings and markers."""

    def __init__(self, fs, root: str):
        self.fs = fs
        self.root = root.rstrip("/")

    def entries(self) -> Tuple[Dict[str, Tuple[str, str]], set]:
        """``{name: (kind, path)}`` of the events directly under the inbox
        (``zip`` objects and ``dir`` prefixes) and the names with a marker
        beside them."""
        entries: Dict[str, Tuple[str, str]] = {}
        markers = set()
        for info in self.fs.ls(self.root, detail=True):
            name = _base(info["name"])
            if not name or name.startswith(".") or name.lower().endswith(_PARTIAL_SUFFIXES):
                continue
            if name.endswith(_DONE):
                markers.add(name[: -len(_DONE)])
            elif info.get("type") == "directory":
                entries[name] = ("dir", info["name"])
            elif name.lower().endswith(".zip"):
                entries[name] = ("zip", info["name"])
        return entries, markers

    def listing(self, kind: str, path: str) -> list:
        """``[(relative name, size, stamp)]`` of an entry, sorted."""
        if kind == "zip":
            info = self.fs.info(path)
            return [("", int(info.get("size") or 0), _stamp(info))]
        prefix = path.rstrip("/") + "/"
        files = self.fs.find(prefix, detail=True)
        out = []
        for name, info in files.items():
            if info.get("type") == "directory":
                continue
            rel = name[len(prefix):] if name.startswith(prefix) else _base(name)
            out.append((rel, int(info.get("size") or 0), _stamp(info)))
        return sorted(out)

    def download(self, kind: str, path: str, listing: list, local: str) -> None:
        """The entry into ``local`` (a path that does not exist yet)."""
        if kind == "zip":
            self.fs.get_file(path, local)
            return
        prefix = path.rstrip("/") + "/"
        os.makedirs(local)
        for rel, _, _ in listing:
            parts = rel.split("/")
            if any(p in ("", ".", "..") for p in parts):
                raise ValueError(f"{prefix}{rel}: a name that would leave the entry")
            target = os.path.join(local, *parts)
            os.makedirs(os.path.dirname(target), exist_ok=True)
            self.fs.get_file(prefix + rel, target)


def _digest(listing: list) -> str:
    return hashlib.sha256(json.dumps(listing, sort_keys=True).encode()).hexdigest()


def _write_atomically(path: str, text: str) -> None:
    tmp = os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.{uuid.uuid4().hex}.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class _Mirror:
    """Complete remote entries → the staging inbox, each marked once whole."""

    def __init__(self, remote: _Remote, staging: str, settle: float, require_done: bool):
        self.remote = remote
        self.staging = staging
        self.settle = settle
        self.require_done = require_done
        # name → (digest, monotonic time the digest was first seen)
        self.seen: Dict[str, Tuple[str, float]] = {}
        self.reported_waiting: set = set()
        # name → digest of the remote zips at rest but not whole
        self.incomplete: Dict[str, str] = {}

    def whole_zip(self, path: str) -> bool:
        """Whether a remote zip's central directory reads (fsspec files are
        seekable: only its end is fetched)."""
        import zipfile

        try:
            with self.remote.fs.open(path, "rb") as f, zipfile.ZipFile(f) as z:
                z.infolist()
            return True
        except (zipfile.BadZipFile, OSError, ValueError, EOFError):
            return False

    def staged_digest(self, name: str) -> Optional[str]:
        try:
            with open(os.path.join(self.staging, name + _DONE), encoding="utf-8") as f:
                return json.load(f).get("digest")
        except (OSError, ValueError):
            return None

    def stage(self, name: str, kind: str, path: str, listing: list, digest: str) -> None:
        tmp = os.path.join(self.staging, f".{name}.{uuid.uuid4().hex}.partial")
        try:
            self.remote.download(kind, path, listing, tmp)
            marker = os.path.join(self.staging, name + _DONE)
            # The marker goes first: the library's watch must not take the
            # old marker for the new files.
            with contextlib.suppress(FileNotFoundError):
                os.remove(marker)
            target = os.path.join(self.staging, name)
            if os.path.isdir(target) and not os.path.islink(target):
                old = tmp + ".old"
                os.rename(target, old)
                os.rename(tmp, target)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(tmp, target)
            _write_atomically(marker, json.dumps({"remote": path, "digest": digest, "files": len(listing)}) + "\n")
        finally:
            if os.path.isdir(tmp):
                shutil.rmtree(tmp, ignore_errors=True)
            elif os.path.exists(tmp):
                os.remove(tmp)

    def poll(self, once: bool = False) -> Tuple[int, int]:
        """One look at the remote inbox: mirrors what became complete.
        Returns (entries mirrored now, entries still settling: changing, or
        unreadable this time).  An inbox that cannot be listed is looked at
        again at the next poll, or, with ``once``, an error."""
        try:
            entries, markers = self.remote.entries()
        except Exception as e:  # a network error: looked at again next poll
            if once:
                raise
            _log("warn", "remote_inbox_unreadable", inbox=self.remote.root, error=repr(e))
            return 0, 0
        now = time.monotonic()
        mirrored = settling = 0
        for name in sorted(entries):
            kind, path = entries[name]
            try:
                listing = self.remote.listing(kind, path)
            except Exception as e:
                _log("warn", "entry_unreadable", entry=name, error=repr(e))
                continue
            digest = _digest(listing)
            if name not in self.seen or self.seen[name][0] != digest:
                self.seen[name] = (digest, now)
            if self.staged_digest(name) == digest:
                continue
            marked = name in markers or (kind == "dir" and any(rel == _DONE for rel, _, _ in listing))
            rested = now - self.seen[name][1] >= self.settle
            if not (marked or (rested and not self.require_done)):
                if name not in self.reported_waiting:
                    self.reported_waiting.add(name)
                    _log("info", "remote_entry_waiting", entry=name,
                         reason="no marker yet" if self.require_done else "changing")
                settling += 0 if self.require_done else 1
                continue
            if kind == "zip" and not marked and not self.whole_zip(path):
                # At rest but not whole (a truncated upload): as the
                # library's watch judges a local one; looked at again when
                # it changes.
                if self.incomplete.get(name) != digest:
                    self.incomplete[name] = digest
                    _log("warn", "entry_incomplete", entry=name,
                         reason="a zip whose central directory does not read")
                continue
            self.incomplete.pop(name, None)
            try:
                self.stage(name, kind, path, listing, digest)
            except Exception as e:
                _log("warn", "entry_unreadable", entry=name, error=repr(e))
                continue
            self.reported_waiting.discard(name)
            mirrored += 1
            _log("info", "remote_entry_mirrored", entry=name, remote=path, files=len(listing), digest=digest[:16])
        return mirrored, settling


_SUMMARY_LISTS = ("processed", "failed", "incomplete")
_SUMMARY_COUNTS = ("notifications_sent", "notifications_dead")


def watch_remote(fs, root: str, staging: str, options: Dict[str, Any], poll: float, settle: float,
                 require_done: bool, once: bool) -> Dict[str, Any]:
    """The mirror loop beside the library's watch over ``staging``."""
    os.makedirs(staging, exist_ok=True)
    mirror = _Mirror(_Remote(fs, root), staging, settle, require_done)
    local = dict(options, inbox=staging, require_done=True, settle=0.0)
    _log("info", "remote_watch_started", inbox=root, staging=staging, settle_s=settle, poll_s=poll,
         require_done=require_done, once=once)
    if once:
        # As `--once`: wait for entries still changing to settle, then
        # process what is complete and exit.
        while True:
            _, settling = mirror.poll(once=True)
            if settling == 0:
                break
            time.sleep(poll)
        summary = json.loads(_native.watch_json(json.dumps(dict(local, once=True))))
        summary["inbox"] = root
        summary["incomplete"] = sorted(set(summary.get("incomplete", [])) | set(mirror.incomplete))
        return summary
    # Until stopped: the library's watch in a thread (it releases the GIL),
    # the mirror here.
    failure: list = []

    def run_native() -> None:
        try:
            _native.watch_json(json.dumps(dict(local, once=False)))
        except BaseException as e:  # noqa: BLE001 - handed to the caller
            failure.append(e)

    thread = threading.Thread(target=run_native, name="quaketwin-watch", daemon=True)
    thread.start()
    while True:
        if failure:
            raise failure[0]
        mirror.poll()
        time.sleep(poll)


def staging_for(out: str) -> str:
    """The default staging inbox: ``DATASET.inbox`` beside the dataset."""
    return os.path.abspath(out).rstrip(os.sep) + ".inbox"


def watch_options(pipeline: str, out: str, notify: Iterable[str], **flags: Any) -> Dict[str, Any]:
    """The library's watch options (``WatchFlags``) of the set keywords."""
    if isinstance(notify, str):
        notify = [notify]
    opts: Dict[str, Any] = {"pipeline": pipeline, "out": out, "notify": list(notify)}
    opts.update({k: v for k, v in flags.items() if v is not None})
    return opts
