"""Figures of a session (``bowlrec session run``): the oil on the lane before and after
(Kegel-style maps and the per-board composite), and the drift of the breakpoint, the entry
board and the entry angle shot by shot.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from bowlrec.bowling.oil import board_volumes_ul
from bowlrec.units import BOARDS

from .oil import BOARD_TICKS, OIL_CMAP, OIL_COLOR, oil_density, on_grid, vector_colorbar
from .render import new_figure

if TYPE_CHECKING:
    from bowlrec.bowling.oil import OilGrid

__all__ = ["DRIFT_METRICS", "drift_figure", "oil_before_after_figure"]

#: (key of a shot dict, axis label) of the drift figure's panels, top to bottom
DRIFT_METRICS = (
    ("breakpoint_board", "breakpoint board"),
    ("breakpoint_ft", "breakpoint distance (ft)"),
    ("entry_board", "entry board at the pins"),
    ("entry_angle_deg", "entry angle (deg)"),
)
#: the bars of the oil after the session
AFTER_COLOR = "#4a6fa5"


def oil_before_after_figure(before: OilGrid, after: OilGrid, *, title: str) -> Figure:
    """The oil on the lane before and after (µL per board per ft, one colour scale), their
    difference (after - before, red where oil was removed, blue where it was laid) as board x
    distance maps, boards counted from the right gutter and the distance from the foul line up;
    and the oil per board over the whole lane before and after (Kegel's composite graph, µL per
    board). ``after`` is shown on ``before``'s cells when they differ (volume conserved)."""
    after = on_grid(after, before)
    d0, d1 = oil_density(before), oil_density(after)
    diff = d1 - d0
    end = max(before.oil_end_ft, after.oil_end_ft, 1.0)
    end = min(float(before.x_edges_ft[-1]), math.ceil(end + 2.0))
    top = max(float(d0.max(initial=0.0)), float(d1.max(initial=0.0)), 1e-9)
    span = max(float(np.abs(diff).max(initial=0.0)), 1e-9)

    fig = new_figure(figsize=(12.0, 4.6), layout="constrained")
    axes = fig.subplots(1, 4, width_ratios=(1.0, 1.0, 1.0, 1.5))
    xs = before.board_edges + 0.5
    ys = before.x_edges_ft
    mesh = None
    for ax, dens, grid, name in ((axes[0], d0, before, "before"), (axes[1], d1, after, "after")):
        mesh = ax.pcolormesh(xs, ys, dens, cmap=OIL_CMAP, vmin=0.0, vmax=top, shading="flat")
        ax.set_title(f"{name}: {float(grid.volume_ul.sum()) / 1000.0:.2f} mL", fontsize=10)
    assert mesh is not None
    vector_colorbar(fig, mesh, ax=axes[:2], label="oil (µL per board per ft)", shrink=0.9)
    norm = TwoSlopeNorm(vcenter=0.0, vmin=-span, vmax=span)
    dm = axes[2].pcolormesh(xs, ys, diff, cmap="RdBu", norm=norm, shading="flat")
    vector_colorbar(fig, dm, ax=axes[2], label="after - before (µL per board per ft)", shrink=0.9)
    axes[2].set_title("difference", fontsize=10)
    for ax in axes[:3]:
        ax.set_xlim(0.5, BOARDS + 0.5)
        ax.set_ylim(0.0, end)
        ax.set_xlabel("board")
        ax.set_xticks(BOARD_TICKS)
    axes[0].set_ylabel("distance from the foul line (ft)")

    boards = np.arange(1, BOARDS + 1)
    b0, b1 = board_volumes_ul(before), board_volumes_ul(after)
    ax = axes[3]
    ax.bar(boards - 0.2, b0, width=0.4, color=OIL_COLOR, label="before")
    ax.bar(boards + 0.2, b1, width=0.4, color=AFTER_COLOR, label="after")
    ax.set_xlim(0.5, BOARDS + 0.5)
    ax.set_xticks(BOARD_TICKS)
    ax.set_xlabel("board")
    ax.set_ylabel("oil over the lane (µL per board)")
    ax.set_title("oil per board", fontsize=10)
    ax.grid(True, axis="y", color="#dddddd", lw=0.6)
    ax.legend(fontsize=8, frameon=False)
    fig.suptitle(title)
    return fig


def _value(shot: Mapping[str, Any], key: str) -> float:
    """The shot's ``key`` as a float (NaN when missing or not a number)."""
    v = shot.get(key)
    try:
        f = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan
    return f


def drift_figure(shots: Sequence[Mapping[str, Any]], *, by: str = "game") -> Figure:
    """The session's drift: per shot (x: its ``shot`` index), the breakpoint board and
    distance, the entry board and the entry angle, a colour per bowler (in order of first
    appearance), and the mean of each group of ``by`` (e.g. "game") as a horizontal line over
    the group's shots. Missing or non-finite values (a gutter ball's entry) are left out.
    Shot dicts carry ``shot``, ``game``, ``bowler`` and the :data:`DRIFT_METRICS` keys."""
    fig = new_figure(figsize=(8.0, 8.5), layout="constrained")
    axes = fig.subplots(len(DRIFT_METRICS), 1, sharex=True)
    bowlers: list[str] = []
    for s in shots:
        name = str(s.get("bowler", ""))
        if name not in bowlers:
            bowlers.append(name)
    colors = [f"C{k % 10}" for k in range(len(bowlers))]
    index = np.array([_value(s, "shot") for s in shots], dtype=np.float64)
    groups: list[Any] = []
    for s in shots:
        g = s.get(by)
        if g not in groups:
            groups.append(g)
    for ax, (key, label) in zip(axes, DRIFT_METRICS, strict=True):
        vals = np.array([_value(s, key) for s in shots], dtype=np.float64)
        for name, color in zip(bowlers, colors, strict=True):
            pick = np.array([str(s.get("bowler", "")) == name for s in shots], dtype=bool)
            ok = pick & np.isfinite(vals) & np.isfinite(index)
            ax.plot(index[ok], vals[ok], "o", ms=3.5, color=color, label=name or "bowler")
        label_mean = f"mean per {by}"
        for g in groups:
            pick = np.array([s.get(by) == g for s in shots], dtype=bool)
            ok = pick & np.isfinite(vals) & np.isfinite(index)
            if np.any(ok):
                lo, hi = float(np.min(index[pick])), float(np.max(index[pick]))
                mean = float(np.mean(vals[ok]))
                ax.plot([lo - 0.4, hi + 0.4], [mean, mean], "-", color="#222222", lw=1.8,
                        label=label_mean)  # fmt: skip
                label_mean = "_nolegend_"
        ax.set_ylabel(label)
        ax.grid(True, color="#dddddd", lw=0.6)
    if not shots:
        axes[0].text(0.5, 0.5, "no shots", transform=axes[0].transAxes, ha="center")
    axes[-1].set_xlabel("shot in the session")
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside upper center", ncol=min(len(labels), 6),
                   fontsize=8, frameon=False)  # fmt: skip
    return fig
