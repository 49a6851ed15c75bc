"""``Modes``: the modes identified from an event (a ``modes`` table and its
``stabilization`` table), with numpy arrays, plots and Jupyter display."""

import html
import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

import pyarrow as pa
import pyarrow.parquet as pq

from ._api import locate_table
from ._optional import need


def _metadata_json(table: Optional[pa.Table], key: str, default: Any) -> Any:
    if table is None or table.schema.metadata is None:
        return default
    raw = table.schema.metadata.get(key.encode())
    if raw is None:
        return default
    try:
        return json.loads(raw)
    except ValueError:
        return default


def _heights(
    ids: Sequence[str], channels: Optional[List[Dict[str, Any]]], structure: Dict[str, Any]
) -> Tuple[List[float], str, bool]:
    """Where each channel sits, for drawing shapes along the building: its
    height above the base from its level and the structure's storey heights,
    else its level, else its position in the list.  Returns the values, the
    axis label and whether they are levels (a base at 0 can be drawn)."""
    by_id = {c.get("id"): c for c in channels or []}
    levels = [by_id.get(i, {}).get("level") for i in ids]
    storeys = structure.get("storey_heights_m") or []
    if levels and all(isinstance(v, int) and 0 <= v <= len(storeys) for v in levels) and storeys:
        return [float(sum(storeys[:v])) for v in levels], "height above the base (m)", True
    if levels and all(isinstance(v, int) for v in levels):
        return [float(v) for v in levels], "level", True
    return [float(k) for k in range(len(ids))], "channel (position in the shape)", False


class Modes:
    """The modes identified from one event.

    Made by :meth:`Event.modal` or :meth:`Modes.read`; wraps the ``modes``
    table (one row per mode, docs/formats.md) and, when known, the
    ``stabilization`` table (every pole of every model order).

    Parameters
    ----------
    modes : pyarrow.Table
        A table in the ``modes/modes.parquet`` schema, with its metadata.
    stabilization : pyarrow.Table, optional
        The matching ``stabilization/stabilization.parquet`` table.
    channels : list of dict, optional
        The channels' metadata (as in ``quaketwin.channels``): their levels
        place the shape components along the building in :meth:`plot`.

    Attributes
    ----------
    table : pyarrow.Table
        The modes.
    stabilization : pyarrow.Table or None
        The poles.
    """

    def __init__(
        self,
        modes: pa.Table,
        stabilization: Optional[pa.Table] = None,
        channels: Optional[List[Dict[str, Any]]] = None,
    ) -> None:
        if not isinstance(modes, pa.Table):
            raise TypeError(f"modes must be a pyarrow Table, not {type(modes).__name__}")
        self.table = modes
        self.stabilization = stabilization
        self._channels = channels

    @classmethod
    def read(cls, path: "str | os.PathLike[str]") -> "Modes":
        """The modes of a run: its output directory or its ``modes/modes.parquet``.

        ``stabilization/stabilization.parquet`` and ``event.json`` (the channels' levels)
        are read too when they lie beside it.
        """
        path = os.fspath(path)
        file = locate_table(path, "modes") if os.path.isdir(path) else path
        if not os.path.exists(file):
            from ._errors import PathNotFoundError

            raise PathNotFoundError(2, f"{file}: no modes table (the output of a run with a modal stage)", file)
        folder = os.path.dirname(file)
        if os.path.basename(folder) == "modes":  # out/modes/modes.parquet: the run is above
            folder = os.path.dirname(folder)
        stabilization = locate_table(folder, "stabilization")
        event = os.path.join(folder, "event.json")
        channels = None
        if os.path.isfile(event):
            with open(event, encoding="utf-8") as f:
                channels = json.load(f).get("channels")
        return cls(
            pq.read_table(file),
            pq.read_table(stabilization) if os.path.isfile(stabilization) else None,
            channels,
        )

    # -- what the table holds -------------------------------------------------

    def __len__(self) -> int:
        return self.table.num_rows

    @property
    def output_channels(self) -> List[str]:
        """The channel of each shape component, in order."""
        return _metadata_json(self.table, "quaketwin.output_channels", [])

    @property
    def directions(self) -> List[str]:
        """The direction label of each shape component (``X``, ``Y`` …)."""
        return _metadata_json(self.table, "quaketwin.output_directions", [])

    @property
    def warnings(self) -> List[str]:
        """Why fewer modes were selected than the stable columns suggest."""
        return _metadata_json(self.table, "quaketwin.warnings", [])

    @property
    def event(self) -> Dict[str, Any]:
        """The event the modes come from (name, origin time, structure)."""
        return _metadata_json(self.table, "quaketwin.event", {})

    @property
    def frequencies_hz(self) -> "Any":
        """Natural frequencies, Hz (numpy array, one per mode)."""
        need("numpy", "Modes.frequencies_hz")
        return self.table.column("frequency_hz").to_numpy()

    @property
    def damping_ratios(self) -> "Any":
        """Damping ratios (numpy array, one per mode; 0.02 = 2 %)."""
        need("numpy", "Modes.damping_ratios")
        return self.table.column("damping_ratio").to_numpy()

    @property
    def frequency_std_data_hz(self) -> "Any":
        """Data-driven standard deviation of each frequency, Hz (numpy array;
        NaN where none was computed): the statistical error of the estimate
        from the record's own blocks (docs/statistics.md, Eqs. S1–S9), not
        the order spread ``frequency_std_hz`` of the table."""
        return self._column_or_nan("frequency_std_data_hz", "Modes.frequency_std_data_hz")

    @property
    def damping_std_data(self) -> "Any":
        """Data-driven standard deviation of each damping ratio (numpy array;
        NaN where none was computed), as :attr:`frequency_std_data_hz`."""
        return self._column_or_nan("damping_std_data", "Modes.damping_std_data")

    @property
    def frequency_intervals_hz(self) -> "Any":
        """95 % intervals of the frequencies, Hz: a numpy array of one row
        ``[low, high]`` per mode, f ± t σ with σ :attr:`frequency_std_data_hz`
        and t Student's t of the σ's degrees of freedom (``uncertainty_dof``,
        Eqs. S8–S8' of docs/statistics.md: wide for an earthquake record whose
        response lies in a few seconds); NaN where no σ."""
        return self._intervals(self.frequencies_hz, self.frequency_std_data_hz)

    @property
    def damping_intervals(self) -> "Any":
        """95 % intervals of the damping ratios, as :attr:`frequency_intervals_hz`."""
        return self._intervals(self.damping_ratios, self.damping_std_data)

    def _column_or_nan(self, name: str, what: str) -> "Any":
        np = need("numpy", what)
        if name not in self.table.column_names:
            return np.full(len(self), np.nan)
        return np.array([np.nan if v is None else v for v in self.table.column(name).to_pylist()], dtype=float)

    def _interval_factors(self) -> "Any":
        """t of each mode's interval: from ``uncertainty_dof``, else (tables
        written before it) ``uncertainty_blocks`` − 1; NaN without either."""
        np = need("numpy", "Modes intervals")
        from . import _native

        dof = self._column_or_nan("uncertainty_dof", "Modes intervals")
        blocks = self._column_or_nan("uncertainty_blocks", "Modes intervals")
        dof = np.where(np.isnan(dof), blocks - 1.0, dof)
        return np.array([_native.interval_factor(float(d)) if np.isfinite(d) else np.nan for d in dof])

    def _intervals(self, value: "Any", std: "Any") -> "Any":
        np = need("numpy", "Modes intervals")
        half = self._interval_factors() * std
        return np.stack([value - half, value + half], axis=1)

    @property
    def shapes(self) -> "Any":
        """Complex mode shapes, a numpy array of one row per mode and one
        column per channel of :attr:`output_channels` (largest component 1)."""
        np = need("numpy", "Modes.shapes")
        re = np.array(self.table.column("shape_re").to_pylist(), dtype=float)
        im = np.array(self.table.column("shape_im").to_pylist(), dtype=float)
        return (re + 1j * im).reshape(len(self), len(self.output_channels))

    def __repr__(self) -> str:
        freqs = ", ".join(f"{f:.3f}" for f in self.table.column("frequency_hz").to_pylist())
        return f"<quaketwin.Modes: {len(self)} modes of {self.event.get('name', '?')!r} at [{freqs}] Hz>"

    def _repr_html_(self) -> str:
        rows = []
        try:
            half = (self.frequency_intervals_hz[:, 1] - self.frequencies_hz).tolist()
        except ImportError:  # without numpy: no intervals
            half = [float("nan")] * len(self)
        for r, h in zip(
            self.table.select(["mode", "frequency_hz", "damping_ratio", "direction", "mpc", "pole_count"]).to_pylist(),
            half,
        ):
            interval = f" ± {h:.4f}" if h == h else ""
            rows.append(
                "<tr><td>{}</td><td>{:.4f}{}</td><td>{:.2f}</td><td>{}</td><td>{:.3f}</td><td>{}</td></tr>".format(
                    r["mode"],
                    r["frequency_hz"],
                    interval,
                    100.0 * r["damping_ratio"],
                    html.escape(r["direction"] or ""),
                    r["mpc"],
                    r["pole_count"],
                )
            )
        notes = "".join(f"<li>{html.escape(w)}</li>" for w in self.warnings)
        return (
            f"<div><strong>{len(self)} modes</strong> of {html.escape(str(self.event.get('name', '')))}"
            "<table><thead><tr><th>mode</th><th>frequency (Hz, 95 % interval)</th><th>damping (%)</th>"
            "<th>direction</th><th>MPC</th><th>poles</th></tr></thead><tbody>"
            + "".join(rows)
            + "</tbody></table>"
            + (f"<details><summary>warnings</summary><ul>{notes}</ul></details>" if notes else "")
            + "</div>"
        )

    # -- plots ----------------------------------------------------------------

    def plot(self, modes: Optional[Sequence[int]] = None, columns: int = 4) -> "Any":
        """Draws the mode shapes along the building (matplotlib).

        One panel per mode: the real part of each component (largest 1)
        against the height of its channel (or its level, or its position
        when the levels are unknown), one line per direction; a dotted line
        joins the lowest channel to the base (not measured).

        Parameters
        ----------
        modes : sequence of int, optional
            The mode numbers to draw (1-based); default: every mode.
        columns : int
            Panels per row.

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = need("matplotlib.pyplot", "Modes.plot")
        rows = self.table.to_pylist()
        if modes is not None:
            wanted = set(modes)
            rows = [r for r in rows if r["mode"] in wanted]
        if not rows:
            raise ValueError("no mode to plot")
        ids = self.output_channels
        directions = self.directions or [""] * len(ids)
        heights, label, base = _heights(ids, self._channels, self.event.get("structure") or {})
        n = len(rows)
        ncols = max(1, min(columns, n))
        nrows = (n + ncols - 1) // ncols
        fig, axes = plt.subplots(nrows, ncols, figsize=(2.6 * ncols, 3.4 * nrows), sharey=True, squeeze=False)
        for ax in axes.flat[n:]:
            ax.set_visible(False)
        for ax, row in zip(axes.flat, rows):
            for d in sorted(set(directions)):
                points = sorted((heights[k], row["shape_re"][k]) for k in range(len(ids)) if directions[k] == d)
                if not points:
                    continue
                y, x = zip(*points)
                (line,) = ax.plot(x, y, marker="o", label=d or "?")
                if base:
                    ax.plot([0.0, x[0]], [0.0, y[0]], linestyle=":", color=line.get_color())
            ax.axvline(0.0, color="0.7", linewidth=0.8)
            ax.set_xlim(-1.1, 1.1)
            ax.set_title(
                f"mode {row['mode']} ({row['direction'] or '?'})\n"
                f"{row['frequency_hz']:.3f} Hz, ζ {100 * row['damping_ratio']:.1f} %",
                fontsize=9,
            )
            ax.set_xlabel("shape (real part)")
        for ax in axes[:, 0]:
            ax.set_ylabel(label)
        axes.flat[0].legend(fontsize=8, title="direction", title_fontsize=8)
        fig.suptitle(f"Mode shapes: {self.event.get('name', '')}", fontsize=10)
        fig.tight_layout()
        return fig

    def plot_stabilization(self) -> "Any":
        """Draws the stabilization diagram (matplotlib): every pole's
        frequency against its model order, the stable physical ones filled,
        the selected modes as vertical lines.

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = need("matplotlib.pyplot", "Modes.plot_stabilization")
        if self.stabilization is None:
            raise ValueError("these modes have no stabilization table (Modes.read found none beside modes/modes.parquet)")
        poles = self.stabilization.to_pydict()
        fig, ax = plt.subplots(figsize=(8, 4.5))
        stable = [
            all(poles[k][i] for k in ("stable_frequency", "stable_damping", "stable_shape", "physical"))
            for i in range(len(poles["order"]))
        ]
        for flag, style in ((False, dict(s=6, c="0.75", label="pole")), (True, dict(s=14, c="C0", label="stable, physical"))):
            f = [poles["frequency_hz"][i] for i in range(len(stable)) if stable[i] == flag]
            o = [poles["order"][i] for i in range(len(stable)) if stable[i] == flag]
            ax.scatter(f, o, **style)
        for k, f in enumerate(self.table.column("frequency_hz").to_pylist()):
            ax.axvline(f, color="C3", linewidth=0.8, label="selected mode" if k == 0 else None)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("model order")
        ax.legend(fontsize=8, loc="upper right")
        ax.set_title(f"Stabilization: {self.event.get('name', '')}", fontsize=10)
        fig.tight_layout()
        return fig
