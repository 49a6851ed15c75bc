"""``Event``: the records of one event in memory (a ``samples`` table and
its channels), with numpy arrays, an ObsPy ``Stream``, plots and Jupyter
display — what ``obspy.read`` gives a seismologist, for a building."""

import html
import json
from typing import Any, Dict, List, Optional, Sequence

import pyarrow as pa
import pyarrow.compute as pc

from . import _api
from ._modes import Modes
from ._optional import need


def _direction(d: Any) -> str:
    """A channel's direction as the library serialises it (``{"Axis": "X"}``,
    ``{"Azimuth": 90.0}``, ``"Up"``) as a label."""
    if isinstance(d, dict):
        for kind, value in d.items():
            return f"{value:g}°" if kind == "Azimuth" and isinstance(value, (int, float)) else str(value)
    return "" if d is None else str(d)


class Event:
    """The records of one event, in memory.

    Made by :func:`quaketwin.read` from an event folder or zip, or from any
    table in the ``samples`` schema (a ``samples/samples.parquet`` read with
    pyarrow: the conditioned records of a run).

    Parameters
    ----------
    samples : pyarrow.Table
        A table in the ``samples`` schema with its ``quaketwin.channels``
        and ``quaketwin.event`` metadata.
    path : str, optional
        Where it was read from (shown only).

    Attributes
    ----------
    samples : pyarrow.Table
        One row per channel and sample (docs/formats.md).
    channels : list of dict
        Every channel's metadata (id, level, direction, role, units,
        sampling rate, source, what was inferred …).
    info : dict
        The event: name, origin time, magnitude, structure, notes.
    """

    def __init__(self, samples: pa.Table, path: Optional[str] = None) -> None:
        if not isinstance(samples, pa.Table):
            raise TypeError(f"samples must be a pyarrow Table, not {type(samples).__name__}")
        meta = samples.schema.metadata or {}
        self.samples = samples
        self.path = path
        self.channels: List[Dict[str, Any]] = json.loads(meta.get(b"quaketwin.channels", b"[]"))
        self.info: Dict[str, Any] = json.loads(meta.get(b"quaketwin.event", b"{}"))

    @property
    def name(self) -> str:
        """The event's name."""
        return self.info.get("name") or ""

    @property
    def channel_ids(self) -> List[str]:
        """The channels' ids, in the table's order."""
        return [c["id"] for c in self.channels]

    def __len__(self) -> int:
        return len(self.channels)

    def __repr__(self) -> str:
        return f"<quaketwin.Event {self.name!r}: {len(self)} channels, {self.samples.num_rows} samples>"

    def _repr_html_(self) -> str:
        counts = {
            r["channel_id"]: r["sample_count"]
            for r in self.samples.group_by("channel_id").aggregate([("sample", "count")]).to_pylist()
        }
        rows = "".join(
            "<tr>"
            + "".join(
                f"<td>{html.escape(str(v))}</td>"
                for v in (
                    c["id"],
                    "" if c.get("level") is None else c["level"],
                    _direction(c.get("direction")),
                    c.get("role") or "",
                    f"{c.get('sampling_rate_hz', 0):g}",
                    counts.get(c["id"], 0),
                )
            )
            + "</tr>"
            for c in self.channels
        )
        structure = self.info.get("structure") or {}
        facts = [
            ("origin time", self.info.get("origin_time")),
            ("magnitude", self.info.get("magnitude")),
            ("structure", structure.get("name")),
        ]
        header = "".join(
            f"<li>{html.escape(k)}: {html.escape(str(v))}</li>" for k, v in facts if v is not None
        )
        return (
            f"<div><strong>{html.escape(self.name)}</strong><ul>{header}</ul>"
            "<table><thead><tr><th>channel</th><th>level</th><th>direction</th><th>role</th>"
            "<th>rate (Hz)</th><th>samples</th></tr></thead><tbody>"
            + rows
            + "</tbody></table></div>"
        )

    # -- data out ---------------------------------------------------------------

    def channel(self, channel_id: str) -> pa.Table:
        """The rows of one channel, in sample order.

        Raises
        ------
        KeyError
            No channel ``channel_id``.
        """
        if channel_id not in self.channel_ids:
            raise KeyError(f"no channel {channel_id!r}; the channels are {', '.join(self.channel_ids)}")
        rows = self.samples.filter(pc.equal(self.samples["channel_id"], channel_id))
        return rows.sort_by("sample")

    def to_numpy(self, column: str = "acc_m_s2") -> Dict[str, Any]:
        """One numpy array per channel (a dict by channel id, in order).

        Parameters
        ----------
        column : str
            ``acc_m_s2`` (default), ``t_s``, or in conditioned tables
            ``vel_m_s`` and ``disp_m``.
        """
        need("numpy", "Event.to_numpy")
        if column not in self.samples.column_names:
            raise KeyError(f"no column {column!r}; the columns are {', '.join(self.samples.column_names)}")
        return {c: self.channel(c).column(column).to_numpy() for c in self.channel_ids}

    def to_obspy(self) -> "Any":
        """The records as an ObsPy ``Stream`` (acceleration, m/s²).

        One ``Trace`` per channel.  Channels read from MiniSEED or SAC keep
        their SEED codes; the others get the quaketwin channel id as station
        code.  ``trace.stats.quaketwin`` holds the channel's quaketwin id,
        level, direction, role and units.  The start time is the first
        sample's ``time`` (the record's start; for a record without one, the
        event's origin time); 1970-01-01 when neither is known.
        ``trace.stats.quaketwin.start_known`` is true only when the record
        states its own start.

        Returns
        -------
        obspy.Stream
        """
        obspy = need("obspy", "Event.to_obspy")
        np = need("numpy", "Event.to_obspy")
        traces = []
        for c in self.channels:
            rows = self.channel(c["id"])
            first = rows.column("time").cast(pa.int64())[0].as_py() if rows.num_rows else None
            start_ns = c.get("start_ns")
            if first is not None:
                start = obspy.UTCDateTime(ns=first)
            elif start_ns is not None:
                start = obspy.UTCDateTime(ns=int(start_ns))
            else:
                start = obspy.UTCDateTime(0)
            seed = all(c.get(k) for k in ("network", "station", "channel_code"))
            stats = {
                "network": (c.get("network") or "") if seed else "",
                "station": c["station"] if seed else c["id"],
                "location": (c.get("location_code") or "") if seed else "",
                "channel": c["channel_code"] if seed else "",
                "sampling_rate": c["sampling_rate_hz"],
                "starttime": start,
                "quaketwin": {
                    "id": c["id"],
                    "level": c.get("level"),
                    "direction": _direction(c.get("direction")),
                    "role": c.get("role"),
                    "units": "m/s^2",
                    "start_known": start_ns is not None,
                },
            }
            data = np.ascontiguousarray(rows.column("acc_m_s2").to_numpy(), dtype=np.float64)
            traces.append(obspy.Trace(data=data, header=stats))
        return obspy.Stream(traces)

    # -- methods ----------------------------------------------------------------

    def modal(self, settings: Optional[Dict[str, Any]] = None) -> Modes:
        """Subspace modal identification of this event, in memory
        (:func:`quaketwin.modal`).

        Parameters
        ----------
        settings : dict, optional
            The ``modal`` stage's parameters (docs/pipelines.md).

        Returns
        -------
        Modes
        """
        modes, stabilization = _api.modal(self.samples, settings)
        return Modes(modes, stabilization, self.channels)

    def plot(self, channels: Optional[Sequence[str]] = None, column: str = "acc_m_s2") -> "Any":
        """Draws the records, one panel per channel (matplotlib).

        Parameters
        ----------
        channels : sequence of str, optional
            Channel ids; default: every channel.
        column : str
            The quantity (``acc_m_s2`` by default).

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = need("matplotlib.pyplot", "Event.plot")
        ids = list(channels) if channels is not None else self.channel_ids
        if not ids:
            raise ValueError("no channel to plot")
        unit = self.samples.schema.field(column).metadata.get(b"unit", b"").decode() if column in self.samples.column_names else ""
        fig, axes = plt.subplots(len(ids), 1, figsize=(9, min(1.3 * len(ids) + 1.0, 30.0)), sharex=True, squeeze=False)
        for ax, cid in zip(axes[:, 0], ids):
            rows = self.channel(cid)
            ax.plot(rows.column("t_s").to_pylist(), rows.column(column).to_pylist(), linewidth=0.6)
            ax.set_ylabel(cid, rotation=0, ha="right", fontsize=8)
            ax.tick_params(labelsize=7)
        axes[-1, 0].set_xlabel("time from the first sample (s)")
        fig.suptitle(f"{self.name} ({column}{', ' + unit if unit else ''})", fontsize=10)
        fig.tight_layout()
        return fig


def read(event: "_api.PathLike") -> Event:
    """Reads an event folder or zip into an :class:`Event` (in memory).

    Parameters
    ----------
    event : str or os.PathLike
        An event folder (with or without ``event.toml``) or zip.

    Returns
    -------
    Event

    Raises
    ------
    PathNotFoundError
        ``event`` does not exist (a ``FileNotFoundError``).
    InputError
        A record cannot be read (the message names the file and where).
    """
    return Event(_api.read_event(event), path=_api._path(event, "event"))
