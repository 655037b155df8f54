"""The lane as the run figures draw it: its friction map shaded by mu, the lane edges and
gutters, the foul line, the targeting arrows, the head pin and a scale of boards.

Axes: x is the distance from the foul line toward the pins (m, horizontal); y the distance from
the right gutter toward the left (m), drawn :attr:`LaneBox.ex` times the x scale so that a hook
is visible. The lane's dimensions come from the run's plan; its markings (39 boards, the arrows
at 15 ft, the head pin on board 20) from :mod:`bowlrec.units`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import PatchCollection
from matplotlib.colors import BoundaryNorm, LinearSegmentedColormap, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from numpy.typing import ArrayLike, NDArray

from bowlrec.spec.run import FrictionCell
from bowlrec.units import ARROWS_FT, BOARDS, FT_M, HEAD_PIN_BOARD

from .render import new_figure

__all__ = [
    "ARROWS_X_M",
    "AXES_WIDTH_IN",
    "FIGURE_WIDTH_IN",
    "GUTTER_PAGE_IN",
    "MAX_DISTINCT_MU",
    "MU_DIGITS",
    "LaneBox",
    "draw_friction",
    "draw_lane_marks",
    "head_pin_y",
    "lane_axes",
    "mu_labels",
]

Array = NDArray[np.float64]

#: the lane's targeting arrows, this far (m) past the foul line
ARROWS_X_M = ARROWS_FT * FT_M
#: page height (inches) of each drawn gutter strip, whatever the exaggeration
GUTTER_PAGE_IN = 0.15
#: page width (inches) of the lane axes
AXES_WIDTH_IN = 9.4
#: total figure width (inches)
FIGURE_WIDTH_IN = 12.0
#: significant digits of a colorbar's mu labels (more only to tell two values apart)
MU_DIGITS = 3
#: up to this many distinct mu values get a discrete colorbar
MAX_DISTINCT_MU = 6

#: lane shading: oil (low mu) darker, dry wood (high mu) lighter, as in the paper's Fig. 4
LANE_CMAP = LinearSegmentedColormap.from_list("bowlrec_lane", ["#b69665", "#f7ecd2"])
EDGE_COLOR = "#3b3024"
GUTTER_COLOR = "#8f9397"
#: the head pin's mark
PIN_COLOR = "#c0282d"


@dataclass(frozen=True)
class LaneBox:
    """The drawn lane: size (m), axes limits (m), width exaggeration and the page scale.

    ``in_per_m`` is the page length (inches) of 1 m along x; 1 m along y is ``ex`` times that.
    """

    length_m: float
    width_m: float
    ex: float
    x_lim: tuple[float, float]
    y_lim: tuple[float, float]
    in_per_m: float

    @classmethod
    def fitting(
        cls, length_m: float, width_m: float, ex: float, x_lim: tuple[float, float], ys: Array
    ) -> LaneBox:
        """The lane drawn over ``x_lim`` (m), AXES_WIDTH_IN wide, with y limits that hold the
        y values ``ys`` (m) and the gutters (GUTTER_PAGE_IN high on the page)."""
        in_per_m = AXES_WIDTH_IN / (x_lim[1] - x_lim[0])
        gutter_m = GUTTER_PAGE_IN / (ex * in_per_m)
        y_lim = (min(-gutter_m, float(ys.min())), max(width_m + gutter_m, float(ys.max())))
        return cls(length_m, width_m, ex, x_lim, y_lim, in_per_m)

    def y_page_in(self, dy_m: float) -> float:
        """Page height (inches) of ``dy_m`` meters across the lane."""
        return dy_m * self.ex * self.in_per_m

    @property
    def board_m(self) -> float:
        """The width of one board (m)."""
        return self.width_m / BOARDS


def head_pin_y(width_m: float) -> float:
    """y (m) of the head pin: the middle of board HEAD_PIN_BOARD, the lane's center line."""
    return (HEAD_PIN_BOARD - 0.5) * width_m / BOARDS


def lane_axes(box: LaneBox, handedness: str = "right") -> tuple[Figure, Axes]:
    """A figure sized so the lane fills its width, with y drawn ``box.ex`` times the x scale:
    y in m from the right gutter (the lane frame) on the left axis, boards in the bowler's
    count of ``handedness`` on the right one.

    The main axes has gid "lane" (its board axis gid "boards"); the figure is saved with a
    tight bounding box, so spare height is trimmed.
    """
    axes_h = box.y_page_in(box.y_lim[1] - box.y_lim[0])
    fig = new_figure(figsize=(FIGURE_WIDTH_IN, axes_h + 2.2), layout="constrained")
    ax = fig.add_subplot()
    ax.set_gid("lane")
    ax.set_xlim(*box.x_lim)
    ax.set_ylim(*box.y_lim)
    ax.set_aspect(box.ex, adjustable="box")
    ax.set_facecolor("white")
    ax.set_xlabel("x, distance from the foul line (m)")
    ax.set_ylabel(f"y from the right gutter (m,\nlane frame; width ×{box.ex:g})")
    ax.set_xticks(np.arange(0.0, box.x_lim[1], 2.0))
    _board_axis(ax, box, handedness)
    return fig, ax


def _board_axis(ax: Axes, box: LaneBox, handedness: str) -> None:
    """A right-hand y axis in boards counted from the bowling hand's gutter (a left-hander's
    board 10 is 10 boards from the left gutter, drawn near the top)."""
    board_m = box.board_m
    left = handedness == "left"
    width_m = box.width_m

    def to_boards(y_m: ArrayLike) -> Array:
        y = np.asarray(y_m, dtype=np.float64)
        return (width_m - y) / board_m if left else y / board_m

    def to_m(boards_: ArrayLike) -> Array:
        b = np.asarray(boards_, dtype=np.float64) * board_m
        return width_m - b if left else b

    boards = ax.secondary_yaxis("right", functions=(to_boards, to_m))
    boards.set_gid("boards")
    side = "left" if left else "right"
    boards.set_ylabel(f"board (bowler's count,\nfrom the {side} gutter)")
    step = 5 if box.y_page_in(box.width_m) > 2.5 else 10
    boards.set_yticks([*range(0, BOARDS - 2, step), BOARDS])


def draw_friction(fig: Figure, ax: Axes, cells: Sequence[FrictionCell]) -> None:
    """Shade each friction cell by mu (oil darker) with a mu colorbar right of the lane.

    Up to MAX_DISTINCT_MU distinct values are shown as discrete shades, evenly spaced from dark
    (lowest mu) to light (highest), with one equal colorbar block per value labeled with it; a
    constant mu gets the middle shade. More values use a continuous scale from min to max mu.
    """
    mus = np.array([c.mu for c in cells])
    values = np.unique(mus)
    rects = [Rectangle((c.x0_m, c.y0_m), c.x1_m - c.x0_m, c.y1_m - c.y0_m) for c in cells]
    coll = PatchCollection(rects, linewidths=0, zorder=0)
    if values.size <= MAX_DISTINCT_MU:
        n = int(values.size)
        shades = [0.5] if n == 1 else list(np.linspace(0.0, 1.0, n))
        coll.set_cmap(ListedColormap([LANE_CMAP(x) for x in shades]))
        coll.set_norm(BoundaryNorm(np.arange(n + 1) - 0.5, ncolors=n))
        coll.set_array(np.searchsorted(values, mus).astype(np.float64))
    else:
        coll.set_cmap(LANE_CMAP)
        coll.set_norm(Normalize(vmin=float(values[0]), vmax=float(values[-1])))
        coll.set_array(mus)
    coll.set_gid("friction")
    ax.add_collection(coll)
    cax = ax.inset_axes((1.07, 0.0, 0.012, 1.0))
    bar = fig.colorbar(coll, cax=cax)
    bar.set_label("friction μ\n(oil darker)")
    if values.size <= MAX_DISTINCT_MU:
        bar.set_ticks(list(range(values.size)), labels=mu_labels(values))
        bar.minorticks_off()


def mu_labels(values: ArrayLike) -> list[str]:
    """Colorbar labels of distinct mu ``values``: MU_DIGITS significant digits (0.188465 ->
    "0.188"), more only where two values would read the same (at most 6)."""
    vs = [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]
    for digits in range(MU_DIGITS, 7):
        labels = [f"{v:.{digits}g}" for v in vs]
        if len(set(labels)) == len(set(vs)):
            return labels
    return [f"{v:.6g}" for v in vs]


def draw_lane_marks(ax: Axes, box: LaneBox, *, pin_label: bool = True) -> None:
    """Gutters, lane edges, foul line, the arrows and the head pin (labeled if ``pin_label``)."""
    _draw_gutters(ax, box)
    length, width = box.length_m, box.width_m
    for y in (0.0, width):
        ax.plot([0.0, length], [y, y], color=EDGE_COLOR, lw=1.0, zorder=2)
    ax.plot([0.0, 0.0], [0.0, width], color=EDGE_COLOR, lw=2.0, zorder=2)
    ax.text(-0.1, width / 2, "foul line", rotation=90, fontsize=8, va="center", ha="right")
    if length > ARROWS_X_M:
        _draw_target_arrows(ax, box)
    pin_y = head_pin_y(width)
    ax.plot(
        [length],
        [pin_y],
        marker="o",
        markersize=9,
        markerfacecolor="white",
        markeredgecolor=PIN_COLOR,
        markeredgewidth=2.0,
        linestyle="none",
        zorder=4,
    )
    if pin_label:
        ax.text(length + 0.15, pin_y, "head\npin", fontsize=8, va="center", ha="left")


def _draw_gutters(ax: Axes, box: LaneBox) -> None:
    """Gray strips below y = 0 (right gutter) and above the lane width (left gutter)."""
    strips = (
        (box.y_lim[0], -box.y_lim[0], "right gutter"),
        (box.width_m, box.y_lim[1] - box.width_m, "left gutter"),
    )
    for y0, h, label in strips:
        ax.add_patch(Rectangle((0.0, y0), box.length_m, h, facecolor=GUTTER_COLOR, lw=0, zorder=0))
        ax.text(0.25, y0 + h / 2, label, fontsize=7, color="white", va="center", zorder=1)


def _draw_target_arrows(ax: Axes, box: LaneBox) -> None:
    """The seven targeting arrows on boards 5, 10, ..., 35 (sized to fit)."""
    board_m = box.board_m
    ys = [b * board_m for b in range(5, BOARDS, 5)]
    spacing_pt = box.y_page_in(5 * board_m) * 72.0
    ax.plot(
        [ARROWS_X_M] * len(ys),
        ys,
        linestyle="none",
        marker=">",
        markersize=min(6.0, 0.7 * spacing_pt),
        color=EDGE_COLOR,
        zorder=2,
    )
    ax.text(
        ARROWS_X_M,
        box.y_lim[0] / 2,
        f"arrows ({ARROWS_FT:g} ft)",
        fontsize=7,
        color="white",
        ha="center",
        va="center",
        zorder=1,
    )
