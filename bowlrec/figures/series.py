"""A run against time: speed, rev rate, slip speed and friction with the run's events
(``bowlrec plot --series``).

:func:`series_figure` builds the figure; :func:`plot_series` writes it as PNG or SVG.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from numpy.typing import NDArray

from bowlrec.core.codes import ROLLING
from bowlrec.spec.run import series_columns

from .render import format_for, new_figure, save_figure
from .trajectory import PNG_DPI, RUN_COLORS, run_label

if TYPE_CHECKING:
    from bowlrec.spec.run import RunData

__all__ = ["SERIES", "plot_series", "series_figure"]

Array = NDArray[np.float64]

#: (column of :func:`bowlrec.spec.run.series_columns`, axis label) of the panels, top to bottom
SERIES = (
    ("speed_mps", "speed (m/s)"),
    ("rev_rate_rpm", "rev rate (rpm)"),
    ("slip_speed_mps", "slip speed (m/s)"),
    ("mu", "friction μ"),
)
#: the shade of rolling intervals
ROLLING_COLOR = "#1b8a3a"
#: line colors of the event kinds; the end-of-run kinds are END_EVENT_COLOR
EVENT_COLORS = {
    "slide_to_roll": "#1b8a3a",
    "roll_to_slide": "#c0282d",
    "zone": "#7a6a55",
    "slip_reversal": "#7b3fa0",
}
END_EVENT_COLOR = "#222222"


def plot_series(run: RunData, path: str | os.PathLike[str], *, title: str | None = None) -> Path:
    """Write the time-series figure of ``run`` to ``path`` (.png or .svg); return the path.

    See :func:`series_figure` for what is drawn; written like
    :func:`bowlrec.figures.trajectory.plot_runs`.
    """
    format_for(path)  # a bad suffix is refused before anything is drawn
    return save_figure(series_figure(run, title=title), path, dpi=PNG_DPI)


def series_figure(run: RunData, *, title: str | None = None) -> Figure:
    """Speed (m/s), rev rate (rpm), slip speed (m/s) and mu against time (s) for ``run``.

    Four panels share the time axis; rolling intervals (phase 1) are shaded light green and
    each event is a dashed vertical line across all panels (gid ``event:<kind>``), colored by
    kind with a legend of the kinds that occur (the run's end event in black). The title is the
    run's legend text of :func:`~bowlrec.figures.trajectory.runs_figure` (name, slide, hook,
    pocket angle or outcome) unless ``title`` is given. Raises
    :class:`~bowlrec.errors.SamplesRequiredError` for a summary-only run.
    """
    run.require_samples("plot")
    traj = run.trajectory
    cols = series_columns(traj)
    fig = new_figure(figsize=(10.0, 8.0), layout="constrained")
    axes = fig.subplots(len(SERIES), 1, sharex=True)
    for ax, (key, label) in zip(axes, SERIES, strict=True):
        values = cols[key][0]
        ax.plot(traj.t_s, values, color=RUN_COLORS[0], lw=1.5)
        ax.set_ylabel(label)
        ax.grid(True, color="#dddddd", lw=0.6)
        ax.set_gid(key)
        _shade_rolling(ax, traj.t_s, np.asarray(traj.phase))
        _event_lines(ax, run)
    axes[-1].set_xlabel("time since release (s)")
    t0, t1 = float(traj.t_s[0]), float(traj.t_s[-1])
    if t1 > t0:
        axes[-1].set_xlim(t0, t1 + 0.01 * (t1 - t0))  # room to see the end event's line
    _event_legend(fig, run)
    fig.suptitle(title if title is not None else run_label(run), fontsize=11)
    return fig


def _rolling_spans(t: Array, phase: NDArray[np.int8]) -> list[tuple[float, float]]:
    """(t_start, t_end) in s of the maximal runs of samples with phase 1 (rolling)."""
    rolling = phase == ROLLING
    spans: list[tuple[float, float]] = []
    start: float | None = None
    for ti, r in zip(t, rolling, strict=True):
        if r and start is None:
            start = float(ti)
        elif not r and start is not None:
            spans.append((start, float(ti)))
            start = None
    if start is not None:
        spans.append((start, float(t[-1])))
    return spans


def _shade_rolling(ax: Axes, t: Array, phase: NDArray[np.int8]) -> None:
    """Light green bands over the rolling intervals (t in s)."""
    for t0, t1 in _rolling_spans(t, phase):
        ax.axvspan(t0, t1, color=ROLLING_COLOR, alpha=0.08, lw=0, zorder=0)


def _event_color(kind: str) -> str:
    """Line color of an event kind (end-of-run kinds are black)."""
    return EVENT_COLORS.get(kind, END_EVENT_COLOR)


def _event_label(kind: str) -> str:
    """Legend text of an event kind: "slide_to_roll" -> "slide → roll", else spaces."""
    return kind.replace("_to_", " → ").replace("_", " ")


def _event_lines(ax: Axes, run: RunData) -> None:
    """One dashed vertical line per event at its time (gid ``event:<kind>``)."""
    for ev in run.trajectory.events:
        line = ax.axvline(ev.t_s, color=_event_color(ev.kind), lw=1.0, ls="--", zorder=1)
        line.set_gid(f"event:{ev.kind}")


def _event_legend(fig: Figure, run: RunData) -> None:
    """Legend of the event kinds that occur (plus the rolling shade), below the panels."""
    kinds = list(dict.fromkeys(ev.kind for ev in run.trajectory.events))
    handles: list[Line2D | Rectangle] = [
        Line2D([], [], color=_event_color(k), lw=1.0, ls="--", label=_event_label(k)) for k in kinds
    ]
    if np.any(np.asarray(run.trajectory.phase) == ROLLING):
        handles.append(Rectangle((0, 0), 1, 1, color=ROLLING_COLOR, alpha=0.15, label="rolling"))
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=9)
