"""The carry map as coaches draw it: strike percentage over entry board (x) x entry angle (y),
one colour scale from 0 to 100 %, every cell annotated with its percentage, and USBC's strike
window (boards 17-18 at 4-6 deg, :data:`USBC_WINDOW`) outlined.

Boards are counted from the bowler's own gutter at the head pin's line (60 ft), fractional; the
board axis runs as the bowler sees the lane (a right-hander's board 1 on the right). Angles in
degrees toward the head pin. The figure is written at its own size and resolution
(:data:`SAVE`), not cropped.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from numpy.typing import ArrayLike, NDArray

from bowlrec.bowling.report import board_count

from .oil import vector_colorbar
from .render import new_figure, save_figure

if TYPE_CHECKING:
    from bowlrec.pins.carry import CarryMap

__all__ = ["SAVE", "USBC_WINDOW", "carry_figure", "strike_heatmap", "write_carry_figure"]

#: USBC's strike window: (board min, board max, angle min deg, angle max deg)
USBC_WINDOW = (17.0, 18.0, 4.0, 6.0)
FIGSIZE_IN = (7.5, 5.0)
DPI = 120
SAVE: dict[str, Any] = {"dpi": None, "tight": False}
CMAP = "viridis"


def _edges(centres: Sequence[float]) -> NDArray[np.float64]:
    """Cell edges around ``centres`` (ascending): midpoints, the ends half a step out."""
    c = np.asarray(centres, dtype=np.float64)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = (c[1:] + c[:-1]) / 2.0
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def strike_heatmap(
    boards: Sequence[float],
    angles_deg: Sequence[float],
    strike_pct: ArrayLike,
    *,
    hand: str = "right",
    n: int | None = None,
    title: str = "",
    window: tuple[float, float, float, float] | None = USBC_WINDOW,
) -> Figure:
    """The heat map of ``strike_pct`` (%, an (angles, boards) array; NaN cells left blank) over
    ``boards`` and ``angles_deg`` (any order); ``n``: repeats per cell, shown in the title;
    ``window``: the outlined window (None: none)."""
    pct = np.asarray(strike_pct, dtype=np.float64)
    if pct.shape != (len(angles_deg), len(boards)):
        raise ValueError(
            f"strike_pct has shape {pct.shape}: it must be (angles, boards) = "
            f"({len(angles_deg)}, {len(boards)})"
        )
    bi, ai = np.argsort(boards), np.argsort(angles_deg)
    pct = pct[np.ix_(ai, bi)]
    boards = [float(boards[k]) for k in bi]
    angles_deg = [float(angles_deg[k]) for k in ai]
    fig = new_figure(figsize=FIGSIZE_IN, dpi=DPI)
    ax = fig.subplots()
    mesh = ax.pcolormesh(
        _edges(boards), _edges(angles_deg), np.ma.masked_invalid(pct), cmap=CMAP,
        vmin=0.0, vmax=100.0, shading="flat",
    )  # fmt: skip
    vector_colorbar(fig, mesh, ax=ax, label="strike %")
    cmap = mesh.get_cmap()
    for i, a in enumerate(angles_deg):
        for j, b in enumerate(boards):
            v = pct[i, j]
            if np.isfinite(v):
                r, g, bl, _ = cmap(v / 100.0)
                dark = 0.299 * r + 0.587 * g + 0.114 * bl < 0.5
                ax.text(b, a, f"{v:.0f}", ha="center", va="center", fontsize=7,
                        color="white" if dark else "black")  # fmt: skip
    if window is not None:
        b0, b1, a0, a1 = window
        ax.add_patch(
            Rectangle((b0, a0), b1 - b0, a1 - a0, fill=False, edgecolor="tab:red", lw=2.0,
                      label=f"USBC window: boards {b0:g}-{b1:g}, {a0:g}-{a1:g} deg")
        )  # fmt: skip
        ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.13), fontsize=8, frameon=False)
    who = "right-hander's" if hand == "right" else "left-hander's"
    gutter = board_count(hand).partition(", ")[2]  # from the bowling hand's gutter
    ax.set_xlabel(f"entry board at the head pin's line ({who} count, {gutter})")
    ax.set_ylabel("entry angle (deg)")
    ax.set_xticks(list(boards))
    ax.set_xticklabels([f"{b:g}" for b in boards], fontsize=7)
    ax.set_yticks(list(angles_deg))
    ax.invert_xaxis()
    reps = f", {n} racks a cell" if n else ""
    head = f"{title}\n" if title else ""
    ax.set_title(f"{head}strike % by entry board and angle{reps}", fontsize=9)
    fig.tight_layout()
    return fig


def carry_figure(cmap: CarryMap, *, title: str = "") -> Figure:
    """:func:`strike_heatmap` of a carry map at its first speed and axis tilt."""
    g = cmap.grid
    return strike_heatmap(
        g.boards,
        g.angles_deg,
        100.0 * cmap.strike_grid(),
        hand=g.base.hand,
        n=g.repeats,
        title=title,
    )


def write_carry_figure(cmap: CarryMap, path: str | os.PathLike[str], *, title: str = "") -> Path:
    """Write :func:`carry_figure` to ``path`` (.png or .svg); return the path."""
    return save_figure(carry_figure(cmap, title=title), path, **SAVE)
