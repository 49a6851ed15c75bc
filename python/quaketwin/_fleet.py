"""The implementation of ``quaketwin.fleet`` (its docstring says what it
does); this module's imports stay out of the public namespace."""

from __future__ import annotations

import argparse
import ast
import contextlib
import errno
import hashlib
import json
import os
import shutil
import socket
import sys
import tempfile
import time
import uuid
from typing import Any, Dict, Iterable, Optional

import pyarrow as pa
import pyarrow.parquet as pq

from . import _native
from ._api import _path as _api_path
from ._api import _track_options
from ._errors import QuaketwinError
from ._optional import need

fsspec = need("fsspec", "quaketwin.fleet")

PART_FILE = "part-0.parquet"
# The table tree (`OUT/tables/<table>/…`), a sibling of the run folders
# (`OUT/runs/…`): no glob under it meets a run's copy (issue 34).
TABLES_DIR = "tables"
RUN_FILES = ("run.json", "event.json", "report.html", "twin_updated.toml")
def _field(name: str, type_: pa.DataType, unit: str, description: str) -> pa.Field:
    """A field with its unit and meaning in its metadata, as every table of
    the Rust library carries them (docs/formats.md)."""
    return pa.field(name, type_, metadata={"unit": unit, "description": description})


FLEET_RUNS_SCHEMA = pa.schema(
    [
        _field("event", pa.string(), "", "the event as given"),
        _field("partition", pa.string(), "", "structure=…/event=… in the dataset; null when the event could not be read"),
        _field("status", pa.string(), "", "ok, skipped (committed before with the same pipeline and event) or failed"),
        _field("error", pa.string(), "", "the exception and its message when failed"),
        _field("seconds", pa.float64(), "s", "wall time of the task"),
        _field("worker", pa.string(), "", "host name of the worker"),
    ]
)


def _fs(url: str, storage_options: Optional[dict]):
    return fsspec.core.url_to_fs(url, **(storage_options or {}))


def _join(root: str, *parts: str) -> str:
    return "/".join([root.rstrip("/")] + [p.strip("/") for p in parts])


def _is_local(fs) -> bool:
    from fsspec.implementations.local import LocalFileSystem

    return isinstance(fs, LocalFileSystem)


def _put_atomically(fs, local: str, remote: str) -> None:
    """Puts ``local`` at ``remote`` so that a reader sees the old file or the
    new one, never a half one.  On a local file system ``local`` (made inside
    the dataset, ``_fleet/work``) is renamed into place: no copy (a copy
    under a temporary name, then a rename, when it is on another device).
    Elsewhere it is written under a temporary name beside ``remote``, then
    moved into place (a rename on POSIX-like file systems; on object stores
    one PUT, itself atomic)."""
    parent = remote.rsplit("/", 1)[0]
    tmp = _join(parent, f".{os.path.basename(remote)}.{uuid.uuid4().hex}.tmp")
    if _is_local(fs):
        os.makedirs(parent, exist_ok=True)
        try:
            os.replace(local, remote)
            return
        except OSError as e:
            if e.errno != errno.EXDEV:
                raise
        try:
            shutil.copyfile(local, tmp)
            os.replace(tmp, remote)
        finally:
            if os.path.lexists(tmp):
                os.remove(tmp)
        return
    fs.makedirs(parent, exist_ok=True)
    fs.put_file(local, tmp)
    fs.mv(tmp, remote)


def _local_event(event: str, workdir: str, storage_options: Optional[dict]) -> str:
    """The event as a local path: itself, or a copy of the URL (folder or zip)."""
    if "://" not in event or event.startswith("file://"):
        return event[len("file://"):] if event.startswith("file://") else event
    fs, path = _fs(event, storage_options)
    name = os.path.basename(path.rstrip("/"))
    target = os.path.join(workdir, name)
    fs.get(path, target, recursive=fs.isdir(path))
    return target


def _commit_path(out: str, partition: str) -> str:
    return _join(out, "_fleet", "commits", partition, "commit.json")


def _work_root(out: str, run_id: str) -> str:
    """Where the tasks of the fleet run ``run_id`` make their run directories
    when the dataset is local: inside it, so that publishing is a rename
    (removed when the run ends, with what a killed worker left there)."""
    return _join(out, "_fleet", "work", run_id)


def process_event(
    pipeline_text: str,
    pipeline_name: str,
    event: str,
    out: str,
    storage_options: Optional[dict] = None,
    run_id: Optional[str] = None,
) -> dict:
    """One event of a fleet: the task a worker runs.

    Parameters
    ----------
    pipeline_text : str
        The pipeline file's text.
    pipeline_name : str
        Its file name.
    event : str
        An event folder, zip or fsspec URL.
    out : str
        The dataset's root (a path or fsspec URL).
    storage_options : dict, optional
        For fsspec.
    run_id : str, optional
        Names the fleet run's work folder inside a local dataset
        (``_fleet/work/RUN_ID``).

    Returns
    -------
    dict
        The event's ``fleet_runs`` row; never raises (a failure is the row's
        ``error``).
    """
    started = time.perf_counter()
    row = {
        "event": event,
        "partition": None,
        "status": "failed",
        "error": None,
        "seconds": 0.0,
        "worker": socket.gethostname(),
    }
    try:
        fs, root = _fs(out, storage_options)
        work_dir = None
        # The run directory on the dataset's own file system: its files
            # are then published by rename (a copy of every table cost
            # ≈ 13 ms an event; docs/performance.md, "Fleet").
        if run_id is not None and _is_local(fs):
            work_dir = _work_root(root, run_id)
            os.makedirs(work_dir, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix="quaketwin-fleet-", dir=work_dir) as work:
            local = _local_event(event, work, storage_options)
            partition = _native.event_partition(local)
            row["partition"] = partition
            identity = {
                "pipeline_sha256": hashlib.sha256(pipeline_text.encode()).hexdigest(),
                "event_fingerprint": _native.event_fingerprint(local),
                "partition": partition,
            }
            commit = _commit_path(root, partition)
            if fs.exists(commit):
                with fs.open(commit, "r") as f:
                    done = json.load(f)
                if all(done.get(k) == v for k, v in identity.items()):
                    row["status"] = "skipped"
                    return row
            pipeline_path = os.path.join(work, pipeline_name)
            with open(pipeline_path, "w", encoding="utf-8") as f:
                f.write(pipeline_text)
            run_dir = os.path.join(work, "run")
            summary = json.loads(_native.run_json(pipeline_path, [local], run_dir, None))
            tables = _native.run_tables(run_dir)
            produced = sorted(t for _, t in tables)
            for file, table in tables:
                _put_atomically(
                    fs, os.path.join(run_dir, file), _join(root, TABLES_DIR, table, partition, PART_FILE)
                )
            # Withdraw the tables an earlier commit of this event published
            # and this run did not produce.
            if fs.exists(commit):
                with fs.open(commit, "r") as f:
                    earlier = json.load(f).get("tables", [])
                for table in sorted(set(earlier) - set(produced)):
                    stale = _join(root, TABLES_DIR, table, partition, PART_FILE)
                    if fs.exists(stale):
                        fs.rm(stale)
            for file in RUN_FILES:
                path = os.path.join(run_dir, file)
                if os.path.isfile(path):
                    _put_atomically(fs, path, _join(root, "runs", partition, file))
            record = dict(identity, tables=produced, ok=summary["ok"])
            local_commit = os.path.join(work, "commit.json")
            with open(local_commit, "w", encoding="utf-8") as f:
                json.dump(record, f, indent=2, sort_keys=True)
            _put_atomically(fs, local_commit, commit)
            row["status"] = "ok"
    except Exception as e:  # every failure is a row, never a stopped fleet
        row["error"] = f"{type(e).__name__}: {e}"
    finally:
        row["seconds"] = time.perf_counter() - started
    return row


def _write_fleet_runs(rows: list, out: str, storage_options: Optional[dict]) -> pa.Table:
    rows = sorted(rows, key=lambda r: r["event"])
    table = pa.Table.from_pylist(rows, schema=FLEET_RUNS_SCHEMA)
    fs, root = _fs(out, storage_options)
    with tempfile.TemporaryDirectory(prefix="quaketwin-fleet-") as work:
        local = os.path.join(work, PART_FILE)
        pq.write_table(table, local)
        _put_atomically(fs, local, _join(root, "fleet_runs", PART_FILE))
    return table


# Dask settings of the cluster `local_cluster` makes.  The worker's
# statistical profiler (a stack sample every 10 ms), the 20 ms event-loop
# tick, the half-second system monitor and work stealing cost an idle
# two-worker cluster 0.9 CPU-seconds every 10 s (4.6 % of this 2-core
# machine); with these 0.14 s.  Tasks of a fleet are whole events, seconds
# long: nothing here needs finer ticks.
QUIET_DASK = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "500ms",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.scheduler.work-stealing-interval": "1s",
}


class ScriptGuardError(QuaketwinError, RuntimeError):
    """A local Dask cluster started from a script's top level without
    ``if __name__ == "__main__":`` (the worker processes would run the
    script again and start clusters of their own)."""

    __module__ = "quaketwin.fleet"


def _is_main_guard(node: ast.stmt) -> bool:
    """``if __name__ == "__main__":`` (either order of the comparison)."""
    if not isinstance(node, ast.If) or not isinstance(node.test, ast.Compare):
        return False
    t = node.test
    if len(t.ops) != 1 or not isinstance(t.ops[0], ast.Eq):
        return False
    sides = [t.left, t.comparators[0]]
    names = [x.id for x in sides if isinstance(x, ast.Name)]
    texts = [x.value for x in sides if isinstance(x, ast.Constant)]
    return names == ["__name__"] and texts == ["__main__"]


def _check_script_guard(what: str) -> None:
    """Raises ``ScriptGuardError`` when the local cluster ``what`` is about
    to start from a script's top level without ``if __name__ ==
    "__main__":``.  Dask starts workers with multiprocessing's "spawn" (or
    "forkserver"), which runs the main script again in every worker:
    unguarded, each would start a cluster of its own and the Nanny fails
    ("Nanny failed to start").  Interactive sessions, notebooks and
    ``python -c`` have no script to run again."""
    import dask

    if dask.config.get("distributed.worker.multiprocessing-method", "spawn") == "fork":
        return
    stack = []
    frame = sys._getframe(1)
    while frame is not None:
        stack.append(frame)
        frame = frame.f_back
    guide = (
        f"{what} starts a local Dask cluster, whose worker processes run this script again; put the "
        'script\'s calls under `if __name__ == "__main__":` (or pass `client=` a cluster started elsewhere)'
    )
    # A worker process running the script again (the parent's check was
    # bypassed, e.g. the script's source could not be read).
    if any(f.f_globals.get("__name__") == "__mp_main__" for f in stack):
        raise ScriptGuardError(f"{guide}: called while a worker process was starting")
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None:
        return
    # What multiprocessing.spawn runs again in a child (its
    # get_preparation_data and _fixup_main_from_name/_path): a main module
    # run by name (`python -m pkg.mod`) unless it is a package's
    # `__main__`; a script run by path unless it is IPython's.
    name = getattr(getattr(main, "__spec__", None), "name", None)
    if name is not None and (name == "__main__" or name.endswith(".__main__")):
        return
    if name is None and os.path.splitext(os.path.basename(path))[0] == "ipython":
        return
    top = [f for f in stack if f.f_globals is main.__dict__ and f.f_code.co_name == "<module>"]
    if not top:
        return
    line = top[-1].f_lineno
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), path)
    except (OSError, SyntaxError, ValueError):
        return
    for node in tree.body:
        if node.lineno <= line <= (node.end_lineno or node.lineno):
            if not _is_main_guard(node):
                raise ScriptGuardError(f"{path}, line {line}: {guide}")
            return


def local_cluster(n_workers: Optional[int] = None, rayon_threads: Optional[int] = None, **kwargs: Any) -> Any:
    """The ``LocalCluster`` that ``run`` makes when given no client.

    One single-threaded worker process per core; the library's own threads
    (rayon) in each capped so that the two levels of parallelism do not
    fight over the cores; workers spawned without Dask's
    ``MALLOC_TRIM_THRESHOLD_=65536`` (with it glibc unmaps and maps again
    every freed block above 64 KiB: ten times the page faults and +20 %
    wall time on half-second events; docs/python.md, "Throughput"); the
    quieter ticks of ``QUIET_DASK``.  Close it (or use it as a context
    manager).

    Parameters
    ----------
    n_workers : int, optional
        Worker processes (default: one per core).
    rayon_threads : int, optional
        Library threads per worker (default: the cores shared among the
        workers).
    **kwargs
        Passed to ``dask.distributed.LocalCluster``.

    Returns
    -------
    dask.distributed.LocalCluster

    Raises
    ------
    ScriptGuardError
        Called from a script's top level without ``if __name__ ==
        "__main__":`` (the message names the line).
    """
    need("distributed", "quaketwin.fleet.local_cluster")
    import dask
    import distributed  # noqa: F401  (loads the distributed config)
    from dask.distributed import LocalCluster

    _check_script_guard("quaketwin.fleet.local_cluster")

    cores = os.cpu_count() or 1
    n_workers = n_workers or cores
    threads = kwargs.pop("threads_per_worker", 1)
    rayon_threads = rayon_threads or max(1, cores // (n_workers * threads))
    environ = {
        k: v
        for k, v in dask.config.get("distributed.nanny.pre-spawn-environ").items()
        if k != "MALLOC_TRIM_THRESHOLD_"
    }
    # A Nanny puts its pre-spawn variables into this process's environment
    # before spawning, so an earlier cluster's threshold would be inherited.
    os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    with dask.config.set(dict(QUIET_DASK, **{"distributed.nanny.pre-spawn-environ": environ})):
        return LocalCluster(
            n_workers=n_workers,
            threads_per_worker=threads,
            processes=True,
            dashboard_address=kwargs.pop("dashboard_address", None),
            # Set in the worker only (a pre-spawn variable would stay in this
            # process's environment, and every command it starts would run
            # on one thread); rayon reads it at its first parallel call.
            env={"RAYON_NUM_THREADS": str(rayon_threads), **kwargs.pop("env", {})},
            **kwargs,
        )


@contextlib.contextmanager
def _cluster(client, **cluster):
    """``client``, or (when None) a client of ``local_cluster(**cluster)``,
    closed on exit."""
    if client is not None:
        yield client
        return
    from dask.distributed import Client

    local = local_cluster(**cluster)
    own = Client(local)
    try:
        yield own
    finally:
        own.close()
        local.close()


def run(
    pipeline: Any,
    events: Iterable[Any],
    out: Any,
    client: Any = None,
    storage_options: Optional[Dict[str, Any]] = None,
    progress: bool = True,
) -> pa.Table:
    """Runs a pipeline on many events over a Dask cluster into one dataset.

    Parameters
    ----------
    pipeline : str or os.PathLike
        A pipeline file.
    events : iterable of str or os.PathLike
        Event folders, zips or fsspec URLs.
    out : str or os.PathLike
        The dataset's root: a path or an fsspec URL (``s3://bucket/ds``).
    client : dask.distributed.Client, optional
        Default: a client of ``local_cluster()``, closed at the end (in a
        script: under ``if __name__ == "__main__":``).
    storage_options : dict, optional
        For fsspec.
    progress : bool
        One line per finished event on stderr.

    Returns
    -------
    pyarrow.Table
        ``fleet_runs``: one row per event (``ok``, ``skipped`` or
        ``failed`` with the error), also written to
        ``OUT/fleet_runs/part-0.parquet``.

    Raises
    ------
    ScriptGuardError
        No client, called from a script's top level without the guard.
    """
    need("distributed", "quaketwin.fleet.run")
    from dask.distributed import as_completed

    pipeline = os.fspath(pipeline)
    with open(pipeline, encoding="utf-8") as f:
        pipeline_text = f.read()
    events = [os.fspath(e) if not isinstance(e, str) else e for e in events]
    out = os.fspath(out) if not isinstance(out, str) else out
    run_id = uuid.uuid4().hex
    with _cluster(client) as client:
        futures = [
            client.submit(
                process_event,
                pipeline_text,
                os.path.basename(pipeline),
                e,
                out,
                storage_options,
                run_id,
                key=f"quaketwin-event-{i}-{uuid.uuid4().hex}",
                retries=2,
                pure=False,
            )
            for i, e in enumerate(events)
        ]
        rows = []
        for done, future in enumerate(as_completed(futures), start=1):
            try:
                row = future.result()
            except Exception as e:  # the task itself could not run (e.g. workers lost)
                i = futures.index(future)
                row = {
                    "event": events[i],
                    "partition": None,
                    "status": "failed",
                    "error": f"{type(e).__name__}: {e}",
                    "seconds": 0.0,
                    "worker": None,
                }
            rows.append(row)
            if progress:
                print(
                    f"[fleet {done}/{len(futures)}] {row['event']}: {row['status']}"
                    + (f" ({row['error']})" if row["error"] else ""),
                    file=sys.stderr,
                )
        fs, root = _fs(out, storage_options)
        if _is_local(fs):
            # Every task has ended: what is left is a killed worker's.
            shutil.rmtree(_work_root(root, run_id), ignore_errors=True)
            with contextlib.suppress(OSError):
                os.rmdir(_join(root, "_fleet", "work"))
        return _write_fleet_runs(rows, out, storage_options)


def _identify_windows(options_json: str, starts: list) -> str:
    """One task of ``track``: identifies the windows starting at ``starts``
    (one UTC day of windows: the day files are indexed once per task)."""
    return _native.track_windows_json(options_json, starts)


def track(archive: Any, out: Any, client: Any = None, **options: Any) -> Dict[str, Any]:
    """``quaketwin track`` with the windows identified over the Dask cluster
    of ``client`` (default: a ``LocalCluster`` of two single-threaded
    workers, closed at the end): one task per UTC day of windows, each
    reading the archive itself (the archive must be readable at the same
    path on every worker: a shared file system), the identified windows
    returned as JSON; this process then tracks, fits the bands and writes
    ``modal_tracking/modal_tracking.parquet`` and ``tracking.html`` into ``out`` (a local
    directory, the command line's output directory rules).  ``options``: as
    ``quaketwin.track``.  Each window is identified by the same code with
    the same settings as on the command line, so the table is the same.

    Parameters
    ----------
    archive, out
        As ``quaketwin.track``.
    client : dask.distributed.Client, optional
        Default: a local cluster of two workers, closed at the end.
    **options
        The options of ``quaketwin.track`` (``window``, ``stationxml`` …);
        another keyword is a ``TypeError``.

    Returns
    -------
    dict
        The summary of ``quaketwin track --json``.
    """
    options_json = _track_options(archive, out, options, "fleet.track")
    starts = _native.track_starts(options_json)
    day_ns = 86_400 * 10**9
    days: dict = {}
    for t in starts:
        days.setdefault(t // day_ns, []).append(t)
    # Two workers, each identifying its day's windows on every core (a
    # handful of day tasks: the cores are used within a task).
    cores = os.cpu_count() or 1
    with _cluster(client, n_workers=min(2, cores), rayon_threads=cores) as client:
        futures = [
            client.submit(_identify_windows, options_json, group,
                          key=f"quaketwin-track-{day}-{uuid.uuid4().hex}", retries=2, pure=False)
            for day, group in sorted(days.items())
        ]
        parts = client.gather(futures)
    return json.loads(_native.track_finish_json(options_json, parts))


def watch(
    inbox: Any,
    pipeline: Any,
    out: Any,
    *,
    staging: Any = None,
    storage_options: Optional[dict] = None,
    notify: Iterable[str] = (),
    poll: Optional[float] = None,
    settle: Optional[float] = None,
    require_done: bool = False,
    once: bool = False,
    dashboard: Any = None,
    no_dashboard: bool = False,
    notify_attempts: Optional[int] = None,
    notify_backoff: Optional[float] = None,
    notify_max_delay: Optional[float] = None,
    notify_timeout: Optional[float] = None,
) -> Dict[str, Any]:
    """``quaketwin watch`` over an inbox on any fsspec file system: a local
    folder, or a prefix of an object store (``s3://bucket/inbox``, polled).

    A local inbox is watched by the library's watch itself.  A remote one is
    mirrored entry by entry into a local staging inbox once an entry is
    complete (a ``NAME.done`` marker, or unchanged for ``settle`` seconds: a
    partial upload is never mirrored), and the library's watch processes
    the staged copies: each event added to the dataset once, notified, the
    structure's history and the dashboard refreshed (docs/monitoring-network.md).

    Parameters
    ----------
    inbox : str or os.PathLike
        The inbox: a folder or an fsspec URL whose entries (``NAME.zip``
        objects, ``NAME/`` prefixes) are events.  Only read.
    pipeline : str or os.PathLike
        The pipeline file run on each event.
    out : str or os.PathLike
        The dataset (a local folder; its state in ``out/_watch/``).
    staging : str or os.PathLike, optional
        The local copy of a remote inbox (default ``out`` + ``.inbox``
        beside the dataset); unused for a local inbox.
    storage_options : dict, optional
        fsspec options of the inbox's file system (credentials, endpoint).
    notify : iterable of str
        Notification targets, as ``--notify``: ``http://…`` or ``cmd:…``.
    poll, settle : float, optional
        Seconds between two looks at the inbox (default 2) and seconds an
        unmarked entry must rest unchanged (default 10).
    require_done : bool
        Only a marker completes an entry.
    once : bool
        Process what is complete, deliver, return (else run until stopped).
    dashboard : str or os.PathLike, optional
        Folder of the dashboard (default ``out/dashboard``).
    no_dashboard : bool
        Do not write the dashboard.
    notify_attempts, notify_backoff, notify_max_delay, notify_timeout : optional
        The delivery retries, as the command's flags (8, 2 s, 600 s, 30 s).

    Returns
    -------
    dict
        With ``once``: the summary of ``quaketwin watch --once --json``
        (``processed``, ``failed``, ``incomplete``, ``notifications_sent``,
        ``notifications_dead``).  Without it the call returns only by an
        exception.
    """
    from . import _watch

    out_path = _api_path(out, "out")
    if "://" in out_path:
        raise ValueError(f"watch: the dataset {out_path!r} must be a local folder")
    options = _watch.watch_options(
        _api_path(pipeline, "pipeline"),
        out_path,
        notify,
        poll=poll,
        settle=settle,
        require_done=require_done,
        dashboard=None if dashboard is None else _api_path(dashboard, "dashboard"),
        no_dashboard=no_dashboard,
        notify_attempts=notify_attempts,
        notify_backoff=notify_backoff,
        notify_max_delay=notify_max_delay,
        notify_timeout=notify_timeout,
    )
    inbox_url = _api_path(inbox, "inbox")
    fs, root = _fs(inbox_url, storage_options)
    if _is_local(fs):
        return json.loads(_native.watch_json(json.dumps(dict(options, inbox=root, once=once))))
    staging_dir = _watch.staging_for(out_path) if staging is None else _api_path(staging, "staging")
    return _watch.watch_remote(
        fs,
        root,
        staging_dir,
        options,
        poll=2.0 if poll is None else float(poll),
        settle=10.0 if settle is None else float(settle),
        require_done=require_done,
        once=once,
    )


def main(argv: Optional[list] = None) -> int:
    """``python -m quaketwin.fleet`` and ``quaketwin fleet``: exit code 0,
    or 1 when an event failed (argparse exits 2 on usage errors)."""
    parser = argparse.ArgumentParser(
        prog="quaketwin fleet",
        description="Run a pipeline on many events over a Dask cluster into a table-first dataset.",
        epilog="Example: quaketwin fleet pipelines/post-earthquake.toml sample-records --out s3://bucket/dataset "
        "--scheduler tcp://scheduler:8786",
    )
    parser.add_argument("pipeline", help="pipeline file (pipelines/*.toml)")
    parser.add_argument("events", nargs="+", help="event folders, zips or URLs; a folder of event folders expands")
    parser.add_argument("--out", required=True, help="dataset root: a path or an fsspec URL")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler (default: a local cluster)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    args = parser.parse_args(argv)
    events = []
    for e in args.events:
        subs = sorted(
            os.path.join(e, d) for d in os.listdir(e)
            if os.path.isdir(os.path.join(e, d)) and os.path.isfile(os.path.join(e, d, "event.toml"))
        ) if os.path.isdir(e) and not os.path.isfile(os.path.join(e, "event.toml")) else []
        events.extend(subs or [e])
    client = None
    if args.scheduler:
        from dask.distributed import Client

        client = Client(args.scheduler)
    table = run(args.pipeline, events, args.out, client=client, progress=not args.quiet)
    failed = [r for r in table.to_pylist() if r["status"] == "failed"]
    for r in failed:
        print(f"quaketwin fleet: {r['event']} failed: {r['error']}", file=sys.stderr)
    return 1 if failed else 0
