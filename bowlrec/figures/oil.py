"""Oil on the lane: a pattern as a pattern sheet draws it (Kegel's graphs), and what the other
oil figures share (an oil grid's density, a grid on another's cells, the board axis, colorbars
drawn as vectors).

Boards are counted 1..39 from the right gutter, as a right-hander counts them (the L/R notation
of a sheet is absolute); distances are in feet from the foul line. The oil stays where the
machine lays it in :func:`pattern_figure` (no buffing or carrydown; :mod:`bowlrec.bowling.oil`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colorbar import Colorbar
from matplotlib.figure import Figure

from bowlrec.bowling.oil import board_volumes_ul, oil_grid, ratio
from bowlrec.units import BOARDS

from .render import new_figure

if TYPE_CHECKING:
    from bowlrec.bowling.oil import KegelPattern, OilGrid, RectanglePattern

__all__ = [
    "BOARD_TICKS",
    "PATTERN_DISTANCES_FT",
    "oil_density",
    "on_grid",
    "pattern_figure",
    "vector_colorbar",
]

#: distances down the lane (ft) of the cross-lane oil curves, kept where there is oil
PATTERN_DISTANCES_FT = (2.0, 10.0, 20.0, 30.0, 36.0, 40.0, 44.0)
#: the boards marked on a board axis
BOARD_TICKS = [1, 5, 10, 15, 20, 25, 30, 35, 39]
#: the colormap of oil density (more oil darker)
OIL_CMAP = "YlOrBr"
#: the bars of oil per board
OIL_COLOR = "#b07a2a"


def oil_density(grid: OilGrid) -> Any:
    """µL per board per ft of every cell of ``grid`` (distance x board)."""
    return grid.volume_ul / np.outer(np.diff(grid.x_edges_ft), np.diff(grid.board_edges))


def on_grid(grid: OilGrid, like: OilGrid) -> OilGrid:
    """``grid`` on the cells of ``like`` (itself if they are the same; volume conserved)."""
    from bowlrec.bowling.oil_transfer import resample_grid

    same = np.array_equal(grid.x_edges_ft, like.x_edges_ft) and np.array_equal(
        grid.board_edges, like.board_edges
    )
    return grid if same else resample_grid(grid, like.x_edges_ft, like.board_edges)


def vector_colorbar(fig: Figure, mappable: ScalarMappable, **kwargs: Any) -> Colorbar:
    """``fig.colorbar(mappable, **kwargs)`` with its scale drawn as vectors (an SVG holds no
    embedded raster)."""
    bar = fig.colorbar(mappable, **kwargs)
    if bar.solids is not None:
        bar.solids.set_rasterized(False)
    return bar


def pattern_figure(pattern: KegelPattern | RectanglePattern, *, title: str | None = None) -> Figure:
    """An oil pattern as a pattern sheet draws it, in three panels over boards 1..39:

    * a board x distance map of the oil density (µL per board per ft; y: ft from the foul line
      to the end of the laid oil);
    * cross-lane curves: the oil density (µL per board per ft) on each board at several
      distances (ft) inside the oil (:data:`PATTERN_DISTANCES_FT`);
    * the oil per board over the whole pattern (µL per board, Kegel's composite graph), with the
      total volume (mL) and the ratio (boards 18..22 over 3..7 and 33..37) in the title.
    """
    grid = oil_grid(pattern)
    end_ft = max(grid.oil_end_ft, 1.0)
    boards = np.arange(1, BOARDS + 1)
    heights = np.diff(grid.x_edges_ft)
    rows = [
        board_volumes_ul(grid, float(x0) + 0.5 * float(h))
        for x0, h in zip(grid.x_edges_ft[:-1], heights, strict=True)
    ]
    density = np.array(rows) if rows else np.zeros((1, BOARDS))
    fig = new_figure(figsize=(11.0, 4.2), layout="constrained")
    ax_map, ax_cross, ax_total = fig.subplots(1, 3, width_ratios=(1.0, 1.3, 1.3))

    edges_x = np.arange(0.5, BOARDS + 1.0)
    edges_y = np.asarray(grid.x_edges_ft, dtype=np.float64)
    if edges_y.size < 2:
        edges_y = np.array([0.0, end_ft])
    mesh = ax_map.pcolormesh(edges_x, edges_y, density, cmap=OIL_CMAP, shading="flat")
    vector_colorbar(fig, mesh, ax=ax_map, label="oil (µL per board per ft)", shrink=0.9)
    ax_map.set_xlim(0.5, BOARDS + 0.5)
    ax_map.set_ylim(0.0, end_ft)
    ax_map.set_xlabel("board")
    ax_map.set_ylabel("distance from the foul line (ft)")
    ax_map.set_title("oil on the lane", fontsize=10)

    distances = [d for d in PATTERN_DISTANCES_FT if d < grid.oil_end_ft]
    for d in distances:
        ax_cross.plot(boards, board_volumes_ul(grid, d), lw=1.4, label=f"{d:g} ft")
    ax_cross.set_xlim(1, BOARDS)
    ax_cross.set_ylim(bottom=0.0)
    ax_cross.set_xlabel("board")
    ax_cross.set_ylabel("oil (µL per board per ft)")
    ax_cross.set_title("cross-lane oil at distances", fontsize=10)
    ax_cross.grid(True, color="#dddddd", lw=0.6)
    if distances:
        ax_cross.legend(fontsize=8, frameon=False)

    totals = board_volumes_ul(grid)
    ax_total.bar(boards, totals, width=0.85, color=OIL_COLOR)
    ax_total.set_xlim(0.5, BOARDS + 0.5)
    ax_total.set_xlabel("board")
    ax_total.set_ylabel("oil over the pattern (µL per board)")
    r = ratio(grid)
    ratio_text = "ratio undefined" if r is None else f"ratio {r:.2f}:1"
    volume_ml = float(np.sum(grid.volume_ul)) / 1000.0
    ax_total.set_title(f"oil per board: {volume_ml:.2f} mL, {ratio_text}", fontsize=10)
    ax_total.grid(True, axis="y", color="#dddddd", lw=0.6)
    for ax in (ax_map, ax_cross, ax_total):
        ax.set_xticks(BOARD_TICKS)
    name = getattr(pattern, "name", None) or "oil pattern"
    fig.suptitle(title if title is not None else f"{name}: oil laid to {grid.oil_end_ft:g} ft")
    return fig
