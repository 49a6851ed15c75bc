"""quaketwin from Python: a thin layer over the Rust library (docs/python.md).

Functions that run a pipeline write the same files as the command line and
return its JSON summary as a dict; ``read_event`` and ``modal`` work on
pyarrow tables in memory (the Arrow C data interface: no copies, no files).
Errors raise ``QuaketwinError`` (``UsageError`` for bad settings or
arguments) with the library's message, which names the file, channel, line
or byte offset where it applies.
"""

from __future__ import annotations

import json
import os
from typing import Any, Optional

import pyarrow as pa
import pyarrow.parquet as pq

from . import _native
from ._native import QuaketwinError, UsageError

__version__ = _native.__version__

__all__ = [
    "QuaketwinError",
    "UsageError",
    "inspect",
    "run",
    "read_event",
    "modal",
    "hysteresis",
    "update",
    "event_partition",
    "track",
]



def _path(p: Any) -> str:
    return os.fspath(p)


def inspect(event) -> dict:
    """The inventory of an event folder or zip: files, channels (all their
    metadata), geometry, notes — the ``event.json`` document."""
    return json.loads(_native.inspect_json(_path(event)))


def run(pipeline, event, out, reference=None) -> dict:
    """Runs a pipeline file on one event into ``out`` (the output directory
    rules of the command line: one event, one run, a lock).  Returns the run
    summary (stages, files, modes, Bouc-Wen status, rating; docs/cli.md)."""
    ref = None if reference is None else _path(reference)
    return json.loads(_native.run_json(_path(pipeline), _path(event), _path(out), ref))


def _track_options(archive, out, options: dict) -> str:
    opts = {"archive": _path(archive), "out": _path(out)}
    for key, value in options.items():
        if value is None:
            continue
        if key in ("stationxml", "reference"):
            value = _path(value)
        opts[key] = value
    return json.dumps(opts)


def track(archive, out, **options) -> dict:
    """Continuous monitoring from an SDS archive (``quaketwin track``,
    docs/monitoring.md) in this process: ``modal_tracking.parquet`` and
    ``tracking.html`` in ``out``.  ``options`` are the command's flags with
    underscores: ``start``, ``end`` (UTC text), ``channels`` (list of
    ``NET.STA.LOC.CHAN`` patterns), ``stationxml``, ``window``, ``step``,
    ``training``, ``cycle`` (durations such as ``"1h"``), ``reference``,
    ``min_present``.  Returns the summary (the command's ``--json``).
    ``quaketwin.fleet.track`` maps the windows over a Dask cluster."""
    return json.loads(_native.track_json(_track_options(archive, out, options)))


def read_event(event) -> pa.Table:
    """The records of an event folder or zip as a pyarrow table in the
    ``samples`` schema (docs/formats.md), as recorded; the channels' metadata
    is in ``table.schema.metadata[b"quaketwin.channels"]`` (JSON)."""
    return _native.read_event(_path(event))


def modal(samples: pa.Table, settings: Optional[dict] = None):
    """Subspace modal identification of the event in ``samples`` (from
    ``read_event`` or a ``samples.parquet``), in memory.  ``settings`` are
    the ``modal`` stage's parameters (docs/pipelines.md), e.g.
    ``{"method": "ssi-cov", "band_hz": [0.5, 15.0]}``.  Returns
    ``(modes, stabilization)`` pyarrow tables in the schemas of
    ``modes.parquet`` and ``stabilization.parquet``; why fewer modes were
    selected than the stable columns suggest is in
    ``modes.schema.metadata[b"quaketwin.warnings"]``."""
    if isinstance(samples, pa.RecordBatch):
        samples = pa.Table.from_batches([samples])
    modes, stabilization, _warnings = _native.modal(samples, json.dumps(settings or {}))
    return modes, stabilization


def hysteresis(event, out) -> dict:
    """Bouc-Wen identification and damage index of an event into ``out``
    (the ``quaketwin hysteresis`` command).  Returns the run summary with
    the tables read back: ``summary["tables"]["bouc_wen"]`` and
    ``["damage"]`` (pyarrow)."""
    summary = json.loads(_native.hysteresis_json(_path(event), _path(out)))
    summary["tables"] = _read_tables(out, ("bouc_wen", "damage"), summary["outputs"])
    return summary


def update(twin, modes, out, settings=None) -> dict:
    """Ensemble update of a twin (TOML) against measured modes: a
    ``modes.parquet``, the run directory holding one, or a pyarrow modes
    table from ``modal`` (written into ``out`` first).  Returns the update
    summary with ``summary["tables"]["twin_update"]`` and
    ``["twin_modes"]`` (pyarrow)."""
    out = _path(out)
    if isinstance(modes, pa.Table):
        os.makedirs(out, exist_ok=True)
        path = os.path.join(out, "measured_modes.parquet")
        pq.write_table(modes, path)
        modes = path
    settings = None if settings is None else _path(settings)
    summary = json.loads(_native.update_json(_path(twin), _path(modes), out, settings))
    summary["tables"] = _read_tables(
        out, ("twin_update", "twin_modes"), ["twin_update.parquet", "twin_modes.parquet"]
    )
    return summary


def event_partition(event) -> str:
    """The Hive partition ``structure=…/event=…`` of an event (the layout of
    many-event runs and of ``quaketwin.fleet``)."""
    return _native.event_partition(_path(event))


def _read_tables(out, names, listed) -> dict:
    tables = {}
    for name in names:
        file = f"{name}.parquet"
        path = os.path.join(_path(out), file)
        if file in listed and os.path.isfile(path):
            tables[name] = pq.read_table(path)
    return tables
