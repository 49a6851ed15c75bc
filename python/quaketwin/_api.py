"""The functions of ``quaketwin``: each calls one function of the native
module (the Rust library) and converts its arguments and results."""

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import pyarrow as pa
import pyarrow.parquet as pq

from . import _native

PathLike = Union[str, "os.PathLike[str]"]

# The options of ``track`` (the fields of the library's TrackOptions but the
# archive and the output directory): one list for ``quaketwin.track`` and
# ``quaketwin.fleet.track``.
TRACK_OPTIONS = (
    "start",
    "end",
    "channels",
    "stationxml",
    "window",
    "step",
    "training",
    "cycle",
    "reference",
    "min_present",
    "temperature",
    "temperature_channel",
)


def _path(p: PathLike, what: str = "path") -> str:
    try:
        return os.fspath(p)
    except TypeError:
        raise TypeError(f"{what} must be a str or os.PathLike, not {type(p).__name__}") from None


def inspect(event: PathLike) -> Dict[str, Any]:
    """The inventory of an event folder or zip (``quaketwin inspect --json``).

    Parameters
    ----------
    event : str or os.PathLike
        An event folder or zip.

    Returns
    -------
    dict
        The ``event.json`` document (docs/formats.md): ``name``,
        ``origin_time``, ``magnitude``, ``structure``, ``files``,
        ``channels`` (every channel's metadata), ``geometry``, ``notes``.

    Raises
    ------
    PathNotFoundError
        ``event`` does not exist (a ``FileNotFoundError``).
    InputError
        A file of the event cannot be read (the message names it).
    """
    return json.loads(_native.inspect_json(_path(event, "event")))


def run(
    pipeline: PathLike,
    event: Union[PathLike, Sequence[PathLike]],
    out: PathLike,
    reference: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Runs a pipeline file on one event, or on many, into ``out``
    (``quaketwin run``).

    The output directory rules of the command line apply: a lock, the run
    manifest ``run.json``, re-runs skip the stages that are up to date.
    Several events, or a folder of event folders, give the many-event
    layout: a Hive dataset ``out/tables/<table>/structure=…/event=…/part-0.parquet``
    that DuckDB, pyarrow and polars read as one table (docs/cli.md).

    Parameters
    ----------
    pipeline : str or os.PathLike
        A pipeline file (``pipelines/*.toml``, docs/pipelines.md).
    event : str, os.PathLike or a sequence of them
        An event folder or zip, a folder of event folders, or a list of events.
    out : str or os.PathLike
        The output directory (made if missing).
    reference : str or os.PathLike, optional
        An earlier run's output directory (or its ``modes/modes.parquet``): adds
        ``frequency_shifts/frequency_shifts.parquet`` (``--reference``).

    Returns
    -------
    dict
        One event: the run summary of ``quaketwin run --json`` (docs/cli.md:
        ``ok``, ``stages``, ``outputs``, ``modes``, ``assessment`` …).  Many:
        ``{"summary_version", "dataset", "events": [run summary, …]}``, where
        an event that failed has ``ok`` false and its ``error`` (the others
        still ran).

    Raises
    ------
    PathNotFoundError
        The pipeline, the event or the reference does not exist.
    UsageError
        The pipeline file or a parameter is wrong (the message names the key).
    QuaketwinError
        The one event's run failed.
    """
    if isinstance(event, (str, os.PathLike)):
        events = [_path(event, "event")]
    else:
        events = [_path(e, "event") for e in event]
    ref = None if reference is None else _path(reference, "reference")
    return json.loads(_native.run_json(_path(pipeline, "pipeline"), events, _path(out, "out"), ref))


def _track_options(archive: PathLike, out: PathLike, options: Dict[str, Any], caller: str) -> str:
    """The options of a track run as the JSON of the library's TrackOptions;
    an unknown option is a TypeError, as for any Python function."""
    unknown = sorted(set(options) - set(TRACK_OPTIONS))
    if unknown:
        raise TypeError(
            f"{caller}() got an unexpected keyword argument {unknown[0]!r} "
            f"(its options: {', '.join(TRACK_OPTIONS)})"
        )
    opts: Dict[str, Any] = {"archive": _path(archive, "archive"), "out": _path(out, "out")}
    for key, value in options.items():
        if value is None:
            continue
        if key in ("stationxml", "reference", "temperature"):
            value = _path(value, key)
        elif key == "channels":
            if isinstance(value, str):
                value = [value]
            value = list(value)
        opts[key] = value
    return json.dumps(opts)


def track(
    archive: PathLike,
    out: PathLike,
    *,
    start: Optional[str] = None,
    end: Optional[str] = None,
    channels: Optional[Sequence[str]] = None,
    stationxml: Optional[PathLike] = None,
    window: Optional[str] = None,
    step: Optional[str] = None,
    training: Optional[str] = None,
    cycle: Optional[str] = None,
    reference: Optional[PathLike] = None,
    min_present: Optional[float] = None,
    temperature: Optional[PathLike] = None,
    temperature_channel: Optional[str] = None,
) -> Dict[str, Any]:
    """Continuous monitoring from an SDS archive in this process
    (``quaketwin track``, docs/monitoring.md).

    Writes ``modal_tracking/modal_tracking.parquet`` and ``tracking.html`` into ``out``.
    ``quaketwin.fleet.track`` identifies the windows over a Dask cluster.

    Parameters
    ----------
    archive : str or os.PathLike
        The root of an SDS archive (``YEAR/NET/STA/CHAN.D/…``).
    out : str or os.PathLike
        The output directory.
    start, end : str, optional
        UTC times (``"2026-01-01T00:00:00Z"``); default: the archive's span.
    channels : sequence of str, optional
        ``NET.STA.LOC.CHAN`` patterns (``?`` and ``*``); default: every stream.
    stationxml : str or os.PathLike, optional
        The StationXML of the streams (gains, orientations).
    window, step, training, cycle : str, optional
        Durations such as ``"1h"``, ``"20m"``: the identification window
        (default 1 h), the step between windows (default: the window), the
        training period of the band (default 24 h) and the environmental
        cycle (default 24 h).
    reference : str or os.PathLike, optional
        Reference modes (a run directory or ``modes/modes.parquet``).
    min_present : float, optional
        Windows with a smaller share of recorded samples are skipped
        (default 0.9).
    temperature : str or os.PathLike, optional
        Measured temperature for the environmental compensation: a CSV of
        time (ISO-8601 UTC or epoch seconds), value.  Without it (and
        without ``temperature_channel``) the latent model compensates.
    temperature_channel : str, optional
        Measured temperature as a stream of the archive
        (``NET.STA.LOC.CHAN``, no wildcard).

    Returns
    -------
    dict
        The summary of ``quaketwin track --json``: ``windows``,
        ``identified_windows``, ``modes``, ``anomaly_from`` …

    Raises
    ------
    TypeError
        An unknown option (a misspelt keyword).
    UsageError
        A bad value (``window="0h"``, a start after the end …).
    PathNotFoundError
        The archive, the StationXML or the reference does not exist.
    """
    options = dict(
        start=start,
        end=end,
        channels=channels,
        stationxml=stationxml,
        window=window,
        step=step,
        training=training,
        cycle=cycle,
        reference=reference,
        min_present=min_present,
        temperature=temperature,
        temperature_channel=temperature_channel,
    )
    return json.loads(_native.track_json(_track_options(archive, out, options, "track")))


def read_event(event: PathLike) -> pa.Table:
    """The records of an event folder or zip as a pyarrow table, in memory.

    Parameters
    ----------
    event : str or os.PathLike
        An event folder or zip.

    Returns
    -------
    pyarrow.Table
        The ``samples`` schema (docs/formats.md), as recorded (SI units, no
        filtering); the channels' metadata as JSON in
        ``table.schema.metadata[b"quaketwin.channels"]``.  ``quaketwin.read``
        wraps the same table in an :class:`Event`.

    Raises
    ------
    PathNotFoundError
        ``event`` does not exist.
    InputError
        A record cannot be read (the message names the file and where).
    """
    return _native.read_event(_path(event, "event"))


def _settings_json(settings: Optional[Dict[str, Any]]) -> str:
    if settings is None:
        return "{}"
    if not isinstance(settings, dict):
        raise TypeError(f"settings must be a dict, not {type(settings).__name__}")
    return json.dumps(settings)


def modal(
    samples: Union[pa.Table, pa.RecordBatch], settings: Optional[Dict[str, Any]] = None
) -> Tuple[pa.Table, pa.Table]:
    """Subspace modal identification of the event in ``samples``, in memory.

    Parameters
    ----------
    samples : pyarrow.Table or pyarrow.RecordBatch
        A ``samples`` table: from :func:`read_event` or a ``samples/samples.parquet``.
    settings : dict, optional
        The ``modal`` stage's parameters (docs/pipelines.md), e.g.
        ``{"method": "ssi-cov", "band_hz": [0.5, 15.0]}``; an unknown key is
        a ``UsageError``.

    Returns
    -------
    modes, stabilization : pyarrow.Table
        In the schemas of ``modes/modes.parquet`` and ``stabilization/stabilization.parquet``,
        with their ``quaketwin.*`` metadata.  ``Event.modal`` returns the
        same as a :class:`Modes`.

    Warns
    -----
    QuaketwinWarning
        Why fewer modes were selected than the stable pole columns suggest
        (also in ``modes.schema.metadata[b"quaketwin.warnings"]``).

    Raises
    ------
    UsageError
        A setting is unknown or out of its range.
    InputError
        ``samples`` is not a samples table.
    """
    if isinstance(samples, pa.RecordBatch):
        samples = pa.Table.from_batches([samples])
    if not isinstance(samples, pa.Table):
        raise TypeError(f"samples must be a pyarrow Table, not {type(samples).__name__}")
    modes, stabilization, _warnings = _native.modal(samples, _settings_json(settings))
    return modes, stabilization


def hysteresis(event: PathLike, out: PathLike) -> Dict[str, Any]:
    """Bouc-Wen identification and damage index of an event into ``out``
    (``quaketwin hysteresis``).

    Parameters
    ----------
    event : str or os.PathLike
        An event folder or zip with base (input) channels.
    out : str or os.PathLike
        The output directory.

    Returns
    -------
    dict
        The run summary, with the tables read back:
        ``summary["tables"]["bouc_wen"]`` and ``["damage"]`` (pyarrow).
    """
    summary = json.loads(_native.hysteresis_json(_path(event, "event"), _path(out, "out")))
    summary["tables"] = _read_tables(out, ("bouc_wen", "damage"), summary["outputs"])
    return summary


def update(
    twin: PathLike,
    modes: Union[PathLike, pa.Table],
    out: PathLike,
    settings: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Ensemble update of a twin against measured modes (``quaketwin update``).

    Parameters
    ----------
    twin : str or os.PathLike
        The twin file (TOML, docs/twin.md).
    modes : str, os.PathLike or pyarrow.Table
        A ``modes/modes.parquet``, the run directory holding one, or a modes table
        from :func:`modal` (written into ``out`` first).
    out : str or os.PathLike
        The output directory.
    settings : str or os.PathLike, optional
        The update settings (TOML).

    Returns
    -------
    dict
        The update summary with ``summary["tables"]["twin_update"]`` and
        ``["twin_modes"]`` (pyarrow).
    """
    out = _path(out, "out")
    if isinstance(modes, pa.Table):
        os.makedirs(out, exist_ok=True)
        os.makedirs(os.path.join(out, "measured_modes"), exist_ok=True)
        path = os.path.join(out, "measured_modes", "measured_modes.parquet")
        pq.write_table(modes, path)
        modes = path
    settings = None if settings is None else _path(settings, "settings")
    summary = json.loads(_native.update_json(_path(twin, "twin"), _path(modes, "modes"), out, settings))
    summary["tables"] = _read_tables(
        out, ("twin_update", "twin_modes"), [table_file("twin_update"), table_file("twin_modes")]
    )
    return summary


def event_partition(event: PathLike) -> str:
    """The Hive partition of an event in a many-event dataset.

    Parameters
    ----------
    event : str or os.PathLike
        An event folder or zip.

    Returns
    -------
    str
        ``structure=…/event=…``: where the event's tables go in a many-event
        dataset (``run`` on several events, ``quaketwin.fleet``).
    """
    return _native.event_partition(_path(event, "event"))


def table_file(name: str) -> str:
    """A table's file relative to a run's output directory.

    Parameters
    ----------
    name : str
        The table (``"modes"``).

    Returns
    -------
    str
        ``"modes/modes.parquet"``: each table in a folder of its own, so that
        ``out/modes/*.parquet`` reads one schema (docs/formats.md).
    """
    return f"{name}/{name}.parquet"


def locate_table(out: PathLike, name: str) -> str:
    """A table's file in a run's output directory.

    Parameters
    ----------
    out : str or os.PathLike
        A run's output directory.
    name : str
        The table (``"modes"``).

    Returns
    -------
    str
        ``out/modes/modes.parquet``, or the flat ``out/modes.parquet`` of a
        run made before the per-table folders when only that exists.
    """
    nested = os.path.join(os.fspath(out), table_file(name))
    flat = os.path.join(os.fspath(out), f"{name}.parquet")
    return flat if not os.path.exists(nested) and os.path.isfile(flat) else nested


def _read_tables(out: PathLike, names: Sequence[str], listed: List[str]) -> Dict[str, pa.Table]:
    tables = {}
    for name in names:
        file = table_file(name)
        path = os.path.join(_path(out), file)
        if file in listed and os.path.isfile(path):
            tables[name] = pq.read_table(path)
    return tables
