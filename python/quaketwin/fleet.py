"""Fleet processing on Dask distributed: many events over a cluster's
workers into one table-first Hive dataset on any fsspec file system
(docs/python.md, "Fleet").

Each event is one task.  A worker copies the event to its local disk when
it is a URL, runs the pipeline into a run directory of its own (the Rust
library, as ``quaketwin run``), then publishes: every table file is written
under a temporary name and moved to
``OUT/tables/<table>/structure=…/event=…/part-0.parquet`` (when ``OUT`` is a local
path the run directory is made inside it, under ``OUT/_fleet/work/``, so that
publishing is one rename per file, never a copy)
(a table the event's new run no longer has is withdrawn), the run's JSON and
HTML go to ``OUT/runs/structure=…/event=…/``, and the event's commit record
``OUT/_fleet/commits/structure=…/event=…/commit.json`` is written last.  A
re-run skips an event whose commit record names the same pipeline text and
event fingerprint; a task that runs twice (a worker lost mid-task is retried
by Dask) writes the same files again, so every event is present exactly
once.  Failures are recorded per event in ``OUT/fleet_runs/part-0.parquet``
instead of stopping the fleet.

Command line: ``python -m quaketwin.fleet PIPELINE EVENT… --out URL
[--scheduler ADDRESS]`` (also ``quaketwin fleet …``).

``watch`` is ``quaketwin watch`` over an inbox on any fsspec file system (an
object-store prefix, polled): complete remote entries are mirrored into a
local staging inbox that the library's watch processes.

In a script, the calls that start a local cluster (``run`` and ``track``
without a client, ``local_cluster``) go under ``if __name__ ==
"__main__":``: Dask starts its worker processes by running the script again
(multiprocessing's "spawn"), and a script without the guard would start a
cluster in every worker.  ``ScriptGuardError`` says so, naming the line,
before any worker starts.
"""

from ._fleet import (
    FLEET_RUNS_SCHEMA,
    QUIET_DASK,
    ScriptGuardError,
    local_cluster,
    main,
    process_event,
    run,
    track,
    watch,
)

__all__ = [
    "FLEET_RUNS_SCHEMA",
    "QUIET_DASK",
    "ScriptGuardError",
    "local_cluster",
    "main",
    "process_event",
    "run",
    "track",
    "watch",
]

if __name__ == "__main__":
    import sys

    sys.exit(main())
