"""Many runs in one lane figure (more than :data:`bowlrec.figures.trajectory.MAX_PLAIN_RUNS`):
a color and line style each, no pair twice; each path numbered on the lane, joined to its end;
the legend in as many columns as fit under the lane.

The colors are evenly spaced hues of one CIELAB lightness, dark against the tan lane and
skipping its tans (:func:`numbered_styles`). Paths that reach the end of the lane are numbered
in columns beyond it, the others in the gutter strip on the side where they end
(:func:`number_runs`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patheffects import withStroke
from matplotlib.text import Annotation
from matplotlib.transforms import offset_copy
from numpy.typing import NDArray

from .lane import FIGURE_WIDTH_IN, LaneBox

__all__ = [
    "MAX_NUMBERED_COLORS",
    "NUMBERED_LEGEND_WIDTH_IN",
    "NUMBERED_LINE_STYLES",
    "number_columns",
    "number_runs",
    "numbered_legend",
    "numbered_styles",
    "numbers_strip_in",
    "reaches_end",
]

Array = NDArray[np.float64]

#: line styles cycled, with the colors, over the paths of a numbered figure
NUMBERED_LINE_STYLES = ("-", "--", ":", "-.")
#: a numbered figure uses a new line style after this many colors
MAX_NUMBERED_COLORS = 10
#: widest page width (inches) of the legend of a numbered figure (under the lane and colorbar)
NUMBERED_LEGEND_WIDTH_IN = 10.5
#: font size (points) of the run numbers on the lane
NUMBER_FONTSIZE = 6.5
#: page distance (inches) between neighbouring run numbers in a column beyond the lane end
NUMBER_STEP_IN = 0.12
#: page distance (inches) from the lane end to the first column of run numbers
NUMBER_X0_IN = 0.1
#: page width (inches) of one column of run numbers
NUMBER_COL_IN = 0.15
#: page distance (inches) between neighbouring run numbers in a gutter strip
NUMBER_GUTTER_STEP_IN = 0.18
#: CIELAB lightness of the colors of a numbered figure (dark against the tan lane)
NUMBERED_LIGHTNESS = 42.0
#: largest CIELAB chroma of the colors of a numbered figure
NUMBERED_MAX_CHROMA = 55.0
#: CIELAB hue range (deg) of the colors of a numbered figure, skipping the lane's tans
NUMBERED_HUES_DEG = (105.0, 410.0)

#: a path ending this close (m) to the lane end, or beyond it, is numbered beyond the lane end
_END_TOLERANCE_M = 0.01
#: CIELAB white point (D65) and the XYZ -> linear sRGB matrix
_D65 = np.array([0.95047, 1.0, 1.08883])
_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)


# --------------------------------------------------------------------------------------------
# colors and styles


def _lab_to_linear_srgb(lightness: float, a: float, b: float) -> Array:
    """Linear sRGB (each in [0, 1] when in gamut) of the CIELAB color (L, a, b), D65 white."""
    fy = (lightness + 16.0) / 116.0
    f = np.array([fy + a / 500.0, fy, fy - b / 200.0])
    delta = 6.0 / 29.0
    xyz = _D65 * np.where(f > delta, f**3, 3.0 * delta**2 * (f - 4.0 / 29.0))
    return np.asarray(_XYZ_TO_SRGB @ xyz, dtype=np.float64)


def _lch_color(lightness: float, hue_deg: float) -> str:
    """Hex sRGB of the CIELAB color of this lightness and hue (deg) with the largest chroma up
    to NUMBERED_MAX_CHROMA that sRGB can show."""
    cos_h, sin_h = math.cos(math.radians(hue_deg)), math.sin(math.radians(hue_deg))
    lo, hi = 0.0, NUMBERED_MAX_CHROMA
    for _ in range(30):  # bisection on the chroma: in gamut at lo, out of gamut above hi
        mid = 0.5 * (lo + hi)
        rgb = _lab_to_linear_srgb(lightness, mid * cos_h, mid * sin_h)
        if np.all((rgb >= 0.0) & (rgb <= 1.0)):
            lo = mid
        else:
            hi = mid
    rgb = np.clip(_lab_to_linear_srgb(lightness, lo * cos_h, lo * sin_h), 0.0, 1.0)
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1.0 / 2.4) - 0.055)
    return "#" + "".join(f"{round(255 * float(c)):02x}" for c in srgb)


def _perceptual_colors(n: int) -> list[str]:
    """``n`` colors of lightness NUMBERED_LIGHTNESS, hues evenly spaced over NUMBERED_HUES_DEG."""
    hues = np.linspace(*NUMBERED_HUES_DEG, n) if n > 1 else np.array([NUMBERED_HUES_DEG[0]])
    return [_lch_color(NUMBERED_LIGHTNESS, float(h)) for h in hues]


def numbered_styles(n_runs: int) -> list[tuple[str, str]]:
    """(color, line style) of each of ``n_runs`` runs, no pair twice.

    The paths cycle through evenly spaced hues and, past MAX_NUMBERED_COLORS colors, through
    NUMBERED_LINE_STYLES; the colors cycle fastest, so runs next to each other in the list
    differ in color.
    """
    n_styles = min(len(NUMBERED_LINE_STYLES), math.ceil(n_runs / MAX_NUMBERED_COLORS))
    n_colors = math.ceil(n_runs / n_styles)
    colors = _perceptual_colors(n_colors)
    return [(colors[k % n_colors], NUMBERED_LINE_STYLES[k // n_colors]) for k in range(n_runs)]


# --------------------------------------------------------------------------------------------
# numbers on the lane


def reaches_end(end_x_m: float, length_m: float) -> bool:
    """True when a path ending at ``end_x_m`` (m) ends at (or beyond) the lane end
    ``length_m`` (m)."""
    return end_x_m >= length_m - _END_TOLERANCE_M


def number_columns(box: LaneBox, n_numbers: int) -> int:
    """Columns of run numbers (NUMBER_STEP_IN apart) that the lane's page height holds."""
    per_column = max(1, int(box.y_page_in(box.y_lim[1] - box.y_lim[0]) // NUMBER_STEP_IN))
    return max(1, math.ceil(n_numbers / per_column))


def numbers_strip_in(box: LaneBox, n_at_end: int) -> float:
    """Page width (inches) beyond the lane end that the columns of the numbers of
    ``n_at_end`` paths reaching it need."""
    return NUMBER_X0_IN + number_columns(box, n_at_end) * NUMBER_COL_IN


def _spread(targets: Sequence[float], step: float, lo: float, hi: float) -> list[float]:
    """Positions at least ``step`` apart in [lo, hi], each as close to its target as it can be.

    ``targets`` are sorted ascending; the positions keep their order. Clusters of positions
    that would be closer than ``step`` are packed at ``step`` spacing around their targets'
    mean (the least-squares placement), then moved inside [lo, hi]. When the positions cannot
    fit, they are spaced evenly from lo to hi.
    """
    n = len(targets)
    if n == 0:
        return []
    if (n - 1) * step > hi - lo:
        return [float(v) for v in np.linspace(lo, hi, n)] if n > 1 else [0.5 * (lo + hi)]
    clusters: list[tuple[int, int, float]] = []  # (first index, size, first position)

    def placed(first: int, size: int) -> float:
        mean = sum(targets[first + i] - i * step for i in range(size)) / size
        return min(max(mean, lo), hi - (size - 1) * step)

    for i in range(n):
        first, size, start = i, 1, placed(i, 1)
        while clusters and clusters[-1][2] + clusters[-1][1] * step > start:
            first, prev_size, _ = clusters.pop()
            size += prev_size
            start = placed(first, size)
        clusters.append((first, size, start))
    return [start + i * step for _, size, start in clusters for i in range(size)]


def number_runs(
    ax: Axes, ends: Sequence[tuple[float, float]], box: LaneBox, colors: Sequence[str]
) -> None:
    """Number run k (its path ending at ``ends[k]``, (x, y) in m) as k + 1 in its color,
    joined by a thin line to its path's end.

    Paths reaching the lane end are numbered in columns beyond it, alternating between the
    columns in order of the end's y and spread NUMBER_STEP_IN apart near their ends' heights;
    the others in the gutter strip on their side of the center line, spread
    NUMBER_GUTTER_STEP_IN apart along x.
    """
    at_end = sorted(
        (k for k, end in enumerate(ends) if reaches_end(end[0], box.length_m)),
        key=lambda k: ends[k][1],
    )
    n_cols = number_columns(box, len(at_end))
    step_y = NUMBER_STEP_IN / (box.ex * box.in_per_m)
    lo_y, hi_y = box.y_lim[0] + 0.5 * step_y, box.y_lim[1] - 0.5 * step_y
    for j in range(n_cols):
        members = at_end[j::n_cols]
        ys = _spread([ends[k][1] for k in members], step_y, lo_y, hi_y)
        x = box.length_m + (NUMBER_X0_IN + j * NUMBER_COL_IN) / box.in_per_m
        for k, y in zip(members, ys, strict=True):
            _run_number(ax, k, ends[k], (x, y), colors[k], "left")
    inside = set(at_end)
    step_x = NUMBER_GUTTER_STEP_IN / box.in_per_m
    for left_side in (False, True):
        members = sorted(
            (
                k
                for k in range(len(ends))
                if k not in inside and (ends[k][1] > box.width_m / 2) == left_side
            ),
            key=lambda k: ends[k][0],
        )
        xs = _spread(
            [ends[k][0] for k in members], step_x, 0.5 * step_x, box.length_m - 0.5 * step_x
        )
        y = 0.5 * (box.width_m + box.y_lim[1]) if left_side else 0.5 * box.y_lim[0]
        for k, x in zip(members, xs, strict=True):
            _run_number(ax, k, ends[k], (x, y), colors[k], "center")


def _run_number(
    ax: Axes, k: int, end: tuple[float, float], at: tuple[float, float], color: str, ha: str
) -> Annotation:
    """The number k + 1 at ``at`` (m), joined to the path's end ``end`` (m); gid run_number:k."""
    number = ax.annotate(
        str(k + 1),
        xy=end,
        xytext=at,
        fontsize=NUMBER_FONTSIZE,
        fontweight="bold",
        color=color,
        ha=ha,
        va="center",
        zorder=8,
        path_effects=[withStroke(linewidth=2.0, foreground="white")],
        arrowprops={"arrowstyle": "-", "color": color, "lw": 0.6, "shrinkA": 1.0, "shrinkB": 0.0},
    )
    number.set_gid(f"run_number:{k}")
    return number


# --------------------------------------------------------------------------------------------
# the legend


def numbered_legend(
    fig: Figure, ax: Axes, labels: Sequence[str], handles: Sequence[Line2D], drop_in: float
) -> Legend:
    """The legend of numbered runs (``labels``, each "k. " + the run's short text) ``drop_in``
    inches below the lane, in as many balanced columns as fit in NUMBERED_LEGEND_WIDTH_IN; the
    figure is made taller to hold it."""
    below = offset_copy(ax.transAxes, fig=fig, y=-drop_in, units="inches")
    fontsize = 8.0
    column_gap_in = 2.0 * fontsize / 72.0

    def legend(ncols: int) -> Legend:
        return ax.legend(
            handles=list(handles),
            labels=list(labels),
            loc="upper center",
            bbox_to_anchor=(0.5, 0.0),
            bbox_transform=below,
            ncols=ncols,
            fontsize=fontsize,
            title_fontsize=8,
            frameon=False,
            handlelength=3.0,
            columnspacing=2.0,
        )

    def width_in(leg: Legend) -> float:
        return float(leg.get_window_extent().width) / fig.dpi

    column_in = width_in(legend(1))
    ncols = max(
        1,
        min(
            len(labels),
            int((NUMBERED_LEGEND_WIDTH_IN + column_gap_in) // (column_in + column_gap_in)),
        ),
    )
    ncols = math.ceil(len(labels) / math.ceil(len(labels) / ncols))  # no empty column
    result = legend(ncols)
    while ncols > 1 and width_in(result) > NUMBERED_LEGEND_WIDTH_IN:
        ncols -= 1
        result = legend(ncols)
    height_in = float(result.get_window_extent().height) / fig.dpi
    ax.set_anchor("N")  # the lane at the top of its space, all spare height below for the legend
    fig.set_size_inches(FIGURE_WIDTH_IN, fig.get_figheight() + height_in)
    return result
