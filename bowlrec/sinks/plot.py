"""Paper-style figures of finished runs (matplotlib, headless).

:func:`plot_runs` draws one or more ball paths over the lane and its oil pattern in the style of
Frohlich (2004), Figs. 1 and 4-6: the lane length runs along the horizontal axis and its width is
exaggerated (4.5 times by default, as in the paper) so that the hook is visible; more than eight
runs are numbered on the lane and in a legend of several columns. :func:`plot_series`
draws speed, rev rate, slip speed and friction against time with the run's events.

:func:`runs_figure` and :func:`series_figure` build the :class:`~matplotlib.figure.Figure`
without writing it (for notebooks and tests). Figures are made with
:class:`matplotlib.figure.Figure` directly, never through pyplot, so no GUI backend or global
state is involved.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import PatchCollection
from matplotlib.colors import (
    BoundaryNorm,
    LinearSegmentedColormap,
    ListedColormap,
    Normalize,
)
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.patheffects import withStroke
from matplotlib.text import Annotation
from matplotlib.transforms import offset_copy
from numpy.typing import ArrayLike, NDArray

from bowlrec.core.codes import ROLLING

from .common import FrictionCell, RunData, friction_cells, series_columns
from .registry import sink_named

__all__ = [
    "PAPER_EXAGGERATION",
    "axis_arrow_samples",
    "plot_runs",
    "plot_series",
    "runs_figure",
    "series_figure",
]

Array = NDArray[np.float64]

#: the paper's exaggeration of the lane width in its trajectory figures (Fig. 1 caption)
PAPER_EXAGGERATION = 4.5
#: the lane's targeting arrows are 15 ft (4.572 m) past the foul line
ARROWS_X_M = 15 * 0.3048
#: a regulation lane has 39 boards
BOARDS_PER_LANE = 39
#: number of rotation-axis arrows drawn along each path
N_AXIS_ARROWS = 10
#: rotation-axis arrows drawn in all in a numbered figure (at least one per run)
NUMBERED_AXIS_ARROWS = 40
#: length on the page (inches) of a rotation-axis arrow whose omega is horizontal
AXIS_ARROW_IN = 0.25
#: page height (inches) of each drawn gutter strip, whatever the exaggeration
GUTTER_PAGE_IN = 0.15
#: page width (inches) of the lane axes
AXES_WIDTH_IN = 9.4
#: distance (inches) from the lane's lower edge down to the legend (room for the x label)
LEGEND_DROP_IN = 0.55
#: widest page width (inches) of the legend of a numbered figure (under the lane and colorbar)
NUMBERED_LEGEND_WIDTH_IN = 10.5
#: up to this many distinct mu values get a discrete colorbar
MAX_DISTINCT_MU = 6
#: total figure width (inches)
FIGURE_WIDTH_IN = 12.0
#: resolution of PNG output (dots per inch)
PNG_DPI = 150
#: up to this many runs get the plain figure (one color each, legend of full-width entries);
#: more runs are numbered (see runs_figure)
MAX_PLAIN_RUNS = 8
#: line styles cycled, with the colors, over the paths of a numbered figure
NUMBERED_LINE_STYLES = ("-", "--", ":", "-.")
#: a numbered figure uses a new line style after this many colors
MAX_NUMBERED_COLORS = 10
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

#: matplotlib format of each suffix the registry gives plots
_FORMATS = {suffix: suffix[1:] for suffix in sink_named("plot").suffixes}
#: run colors, chosen to stand out on the tan lane (no browns or oranges)
_RUN_COLORS = (
    "#1f4e9c",
    "#c0282d",
    "#1b8a3a",
    "#7b3fa0",
    "#0a8a99",
    "#d4458f",
    "#222222",
    "#5c6bc0",
)
#: lane shading: oil (low mu) darker, dry wood (high mu) lighter, as in the paper's Fig. 4
_LANE_CMAP = LinearSegmentedColormap.from_list("bowlrec_lane", ["#b69665", "#f7ecd2"])
_EDGE_COLOR = "#3b3024"
_GUTTER_COLOR = "#8f9397"
_EVENT_COLORS = {
    "slide_to_roll": "#1b8a3a",
    "roll_to_slide": "#c0282d",
    "zone": "#7a6a55",
    "slip_reversal": "#7b3fa0",
}
_END_EVENT_COLOR = "#222222"


# --------------------------------------------------------------------------------------------
# writing


def _format_for(path: Path) -> str:
    """The matplotlib format for ``path``'s suffix; ValueError unless .png or .svg."""
    fmt = _FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"cannot plot to {str(path)!r}: the file name must end in .png or .svg "
            f"(got suffix {path.suffix!r})"
        )
    return fmt


def _new_file_mode(path: Path) -> int:
    """Permissions for the written file: those of the file it replaces, else 0o666 & ~umask."""
    try:
        return path.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0o022)
        os.umask(umask)
        return 0o666 & ~umask


def _save_atomic(fig: Figure, path: Path, fmt: str) -> Path:
    """Write ``fig`` to a temporary file next to ``path`` (its directory created if missing),
    then rename it over ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = _new_file_mode(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "wb") as fh:
            fig.savefig(fh, format=fmt, dpi=PNG_DPI, bbox_inches="tight", pad_inches=0.15)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def plot_runs(
    runs: Sequence[RunData],
    path: str | os.PathLike[str],
    *,
    exaggerate: float | None = None,
    title: str | None = None,
) -> Path:
    """Write the paper-style lane figure of ``runs`` to ``path`` (.png or .svg); return the path.

    See :func:`runs_figure` for what is drawn. The file is written atomically (a temporary file
    in the same directory, then renamed). Raises ValueError for another suffix, for no runs, and
    (as :class:`~bowlrec.sinks.SamplesRequiredError`) for a summary-only run.
    """
    out = Path(path)
    fmt = _format_for(out)
    fig = runs_figure(runs, exaggerate=exaggerate, title=title)
    return _save_atomic(fig, out, fmt)


def write_plot(run: RunData, path: str | os.PathLike[str]) -> Path:
    """:func:`plot_runs` of the one run ``run`` (the registry's writer)."""
    return plot_runs([run], path)


def plot_series(run: RunData, path: str | os.PathLike[str], *, title: str | None = None) -> Path:
    """Write the time-series figure of ``run`` to ``path`` (.png or .svg); return the path.

    See :func:`series_figure` for what is drawn; written atomically like :func:`plot_runs`.
    """
    out = Path(path)
    fmt = _format_for(out)
    fig = series_figure(run, title=title)
    return _save_atomic(fig, out, fmt)


# --------------------------------------------------------------------------------------------
# the lane figure


@dataclass(frozen=True)
class _LaneBox:
    """The drawn lane: size (m), axes limits (m), width exaggeration and the page scale.

    ``in_per_m`` is the page length (inches) of 1 m along x; 1 m along y is ``ex`` times that.
    """

    length_m: float
    width_m: float
    ex: float
    x_lim: tuple[float, float]
    y_lim: tuple[float, float]
    in_per_m: float

    def y_page_in(self, dy_m: float) -> float:
        """Page height (inches) of ``dy_m`` meters across the lane."""
        return dy_m * self.ex * self.in_per_m

    def number_columns(self, n_numbers: int) -> int:
        """Columns of run numbers (NUMBER_STEP_IN apart) that the lane's page height holds."""
        per_column = max(1, int(self.y_page_in(self.y_lim[1] - self.y_lim[0]) // NUMBER_STEP_IN))
        return max(1, math.ceil(n_numbers / per_column))


def runs_figure(
    runs: Sequence[RunData],
    *,
    exaggerate: float | None = None,
    title: str | None = None,
) -> Figure:
    """The lane figure of ``runs`` as a :class:`~matplotlib.figure.Figure` (not written).

    Axes: x is the distance from the foul line toward the pins (m, horizontal); y is the
    distance from the right gutter toward the left (m on the left axis, boards counted from the
    right gutter on the right axis; a lane has 39 boards), so a ball hooking left goes up. The
    width is drawn ``exaggerate`` times (default 4.5, the paper's value) the length scale.

    Drawn: the friction map of the first run's lane (cells shaded by mu, oil darker, with a mu
    colorbar), the lane edges and gutters, the foul line, the targeting arrows at 15 ft
    (4.572 m) on boards 5, 10, ..., 35 and the head pin at the end of the lane on the center
    line. For each run, in its own color: the path of the ball's center, a dashed straight line
    along the release velocity (the hook is measured from it), a tick mark where the ball first
    starts rolling (``summary.slide_m``), and rotation-axis arrows at N_AXIS_ARROWS (10) evenly
    spaced points along the path (with more than MAX_PLAIN_RUNS runs, fewer: about
    NUMBERED_AXIS_ARROWS in all, at least one per run). Several runs are staggered along the
    path so their arrows do not sit on top of each other.

    Rotation-axis arrows show the horizontal part of the unit vector omega/|omega|. They are
    drawn in page (display) coordinates, not data coordinates: the angle of an arrow on the
    page is the true angle of omega in the lane (undistorted by the exaggerated width), and its
    length is AXIS_ARROW_IN inches times the horizontal fraction of omega (a shorter arrow is a
    more steeply inclined axis). The path itself is exaggerated, so its angles on the page are
    steeper than in the lane.

    The legend has one entry per run: its name, slide (m; "no roll" if it never rolls), hook
    (cm) and pocket angle (deg), or the outcome when the ball does not reach the pins.

    Up to MAX_PLAIN_RUNS runs, each has its own color from a fixed palette and the legend sits
    below the lane. More runs are numbered 1, 2, ... in order: the paths cycle through
    evenly spaced hues of one CIELAB lightness (dark against the lane, skipping its tans) and,
    past MAX_NUMBERED_COLORS colors, through the line styles NUMBERED_LINE_STYLES, so no two
    runs share both color and style. Each path carries its number (gid ``run_number:k``,
    joined to the path's end by a thin line): paths that reach the end of the lane are numbered
    in columns beyond it, the others in the gutter strip on the side where they end. The
    legend entries start with the numbers and fill as many columns as fit under the lane; the
    figure grows in height with the legend, so the lane keeps the size it has for a few runs
    (it is drawn a little shorter only when the numbers need more than the two columns that
    fit beyond the lane end, about 40 runs that reach the pins). The head pin's label moves to
    the symbol key.

    Raises ValueError if ``runs`` is empty or ``exaggerate`` is not positive and finite, and
    :class:`~bowlrec.sinks.SamplesRequiredError` for a summary-only run.
    """
    if len(runs) == 0:
        raise ValueError("plot needs at least one run")
    for run in runs:
        run.require_samples("plot")
    ex = PAPER_EXAGGERATION if exaggerate is None else float(exaggerate)
    if not (math.isfinite(ex) and ex > 0.0):
        raise ValueError(f"exaggerate = {exaggerate!r} must be a positive finite number")

    numbered = len(runs) > MAX_PLAIN_RUNS
    box = _lane_box(runs, ex, numbered=numbered)
    fig, ax = _lane_axes(box)
    _draw_friction(fig, ax, friction_cells(runs[0].plan))
    _draw_lane_marks(ax, box, pin_label=not numbered)
    if numbered:
        styles = _numbered_styles(len(runs))
    else:
        styles = [(_RUN_COLORS[k % len(_RUN_COLORS)], "-") for k in range(len(runs))]
    handles: list[Line2D] = []
    for k, (run, (color, style)) in enumerate(zip(runs, styles, strict=True)):
        handles.append(_draw_run(ax, run, k, len(runs), color, style))
    if numbered:
        _number_runs(ax, runs, box, [color for color, _ in styles])
        legend = _numbered_legend(fig, ax, runs, handles)
    else:
        legend = _run_legend(fig, ax, handles)
    if _lanes_differ(runs):
        legend.set_title(f"lane and oil pattern drawn: those of {runs[0].name} (the lanes differ)")
    _symbol_key(ax, numbered=numbered)
    _lane_title(ax, runs, title)
    return fig


def _lane_box(runs: Sequence[RunData], ex: float, *, numbered: bool = False) -> _LaneBox:
    """The first run's lane, with axes limits that hold every path, the head pin and gutters.

    Gutters are drawn GUTTER_PAGE_IN high on the page whatever the exaggeration. With
    ``numbered``, the space beyond the lane end is widened when the run numbers placed there
    (see :func:`_number_runs`) need more columns than it holds.
    """
    length = float(runs[0].plan.lane_length_m)
    width = float(runs[0].plan.lane_width_m)
    ys = np.concatenate([r.trajectory.position_m[:, 1] for r in runs])
    xs = np.concatenate([r.trajectory.position_m[:, 0] for r in runs])
    x0 = min(-0.5, float(xs.min()) - 0.2)
    x1 = max(length + 0.9, float(xs.max()) + 0.3)

    def box_to(x1: float) -> _LaneBox:
        in_per_m = AXES_WIDTH_IN / (x1 - x0)
        gutter_m = GUTTER_PAGE_IN / (ex * in_per_m)
        y_lim = (min(-gutter_m, float(ys.min())), max(width + gutter_m, float(ys.max())))
        return _LaneBox(length, width, ex, (x0, x1), y_lim, in_per_m)

    box = box_to(x1)
    if not numbered:
        return box
    n_end = sum(_reaches_end(r, length) for r in runs)
    for _ in range(8):  # a wider strip shrinks the scale, so a column holds fewer numbers
        strip_in = NUMBER_X0_IN + box.number_columns(n_end) * NUMBER_COL_IN
        share = strip_in / AXES_WIDTH_IN  # solves x1 - length = share * (x1 - x0) for x1
        needed = (length - share * x0) / (1.0 - share)
        if needed <= box.x_lim[1] + 1e-9:
            break
        box = box_to(needed)
    return box


def _lane_axes(box: _LaneBox) -> tuple[Figure, Axes]:
    """A figure sized so the lane fills its width, with y drawn ``box.ex`` times the x scale.

    The main axes has gid "lane"; the figure is saved with a tight bounding box, so spare
    height is trimmed.
    """
    axes_h = box.y_page_in(box.y_lim[1] - box.y_lim[0])
    fig = Figure(figsize=(FIGURE_WIDTH_IN, axes_h + 2.2), layout="constrained")
    ax = fig.add_subplot()
    ax.set_gid("lane")
    ax.set_xlim(*box.x_lim)
    ax.set_ylim(*box.y_lim)
    ax.set_aspect(box.ex, adjustable="box")
    ax.set_facecolor("white")
    ax.set_xlabel("x, distance from the foul line (m)")
    ax.set_ylabel(f"y from right gutter (m)\n(width ×{box.ex:g})")
    ax.set_xticks(np.arange(0.0, box.x_lim[1], 2.0))
    _board_axis(ax, box)
    return fig, ax


def _board_axis(ax: Axes, box: _LaneBox) -> None:
    """A right-hand y axis in boards counted from the right gutter (39 boards per lane)."""
    board_m = box.width_m / BOARDS_PER_LANE

    def to_boards(y_m: ArrayLike) -> Array:
        return np.asarray(y_m, dtype=np.float64) / board_m

    def to_m(boards_: ArrayLike) -> Array:
        return np.asarray(boards_, dtype=np.float64) * board_m

    boards = ax.secondary_yaxis("right", functions=(to_boards, to_m))
    boards.set_ylabel("board (from right)")
    step = 5 if box.y_page_in(box.width_m) > 2.5 else 10
    boards.set_yticks([*range(0, BOARDS_PER_LANE - 2, step), BOARDS_PER_LANE])


def _draw_friction(fig: Figure, ax: Axes, cells: Sequence[FrictionCell]) -> None:
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
        coll.set_cmap(ListedColormap([_LANE_CMAP(x) for x in shades]))
        coll.set_norm(BoundaryNorm(np.arange(n + 1) - 0.5, ncolors=n))
        coll.set_array(np.searchsorted(values, mus).astype(np.float64))
    else:
        coll.set_cmap(_LANE_CMAP)
        coll.set_norm(Normalize(vmin=float(values[0]), vmax=float(values[-1])))
        coll.set_array(mus)
    coll.set_gid("friction")
    ax.add_collection(coll)
    cax = ax.inset_axes((1.07, 0.0, 0.012, 1.0))
    bar = fig.colorbar(coll, cax=cax)
    bar.set_label("friction μ\n(oil darker)")
    if values.size <= MAX_DISTINCT_MU:
        bar.set_ticks(list(range(values.size)), labels=[f"{v:g}" for v in values])
        bar.minorticks_off()


def _draw_lane_marks(ax: Axes, box: _LaneBox, *, pin_label: bool = True) -> None:
    """Gutters, lane edges, foul line, 15 ft arrows and the head pin (labeled if ``pin_label``)."""
    _draw_gutters(ax, box)
    length, width = box.length_m, box.width_m
    for y in (0.0, width):
        ax.plot([0.0, length], [y, y], color=_EDGE_COLOR, lw=1.0, zorder=2)
    ax.plot([0.0, 0.0], [0.0, width], color=_EDGE_COLOR, lw=2.0, zorder=2)
    ax.text(-0.1, width / 2, "foul line", rotation=90, fontsize=8, va="center", ha="right")
    if length > ARROWS_X_M:
        _draw_target_arrows(ax, box)
    ax.plot(
        [length],
        [width / 2],
        marker="o",
        markersize=9,
        markerfacecolor="white",
        markeredgecolor="#c0282d",
        markeredgewidth=2.0,
        linestyle="none",
        zorder=4,
    )
    if pin_label:
        ax.text(length + 0.15, width / 2, "head\npin", fontsize=8, va="center", ha="left")


def _draw_gutters(ax: Axes, box: _LaneBox) -> None:
    """Gray strips below y = 0 (right gutter) and above the lane width (left gutter)."""
    strips = (
        (box.y_lim[0], -box.y_lim[0], "right gutter"),
        (box.width_m, box.y_lim[1] - box.width_m, "left gutter"),
    )
    for y0, h, label in strips:
        ax.add_patch(Rectangle((0.0, y0), box.length_m, h, facecolor=_GUTTER_COLOR, lw=0, zorder=0))
        ax.text(0.25, y0 + h / 2, label, fontsize=7, color="white", va="center", zorder=1)


def _draw_target_arrows(ax: Axes, box: _LaneBox) -> None:
    """The seven targeting arrows at 15 ft on boards 5, 10, ..., 35 (sized to fit)."""
    board_m = box.width_m / BOARDS_PER_LANE
    ys = [b * board_m for b in range(5, BOARDS_PER_LANE, 5)]
    spacing_pt = box.y_page_in(5 * board_m) * 72.0
    ax.plot(
        [ARROWS_X_M] * len(ys),
        ys,
        linestyle="none",
        marker=">",
        markersize=min(6.0, 0.7 * spacing_pt),
        color=_EDGE_COLOR,
        zorder=2,
    )
    ax.text(
        ARROWS_X_M,
        box.y_lim[0] / 2,
        "arrows (15 ft)",
        fontsize=7,
        color="white",
        ha="center",
        va="center",
        zorder=1,
    )


def _draw_run(ax: Axes, run: RunData, k: int, n_runs: int, color: str, style: str = "-") -> Line2D:
    """Path (in line style ``style``), straight reference, slide-to-roll tick and omega arrows
    of run ``k``; the path."""
    traj = run.trajectory
    x, y = traj.position_m[:, 0], traj.position_m[:, 1]
    (line,) = ax.plot(x, y, color=color, ls=style, lw=1.8, zorder=5, label=_run_label(run))
    line.set_gid(f"path:{k}")
    _draw_straight(ax, run, color)
    _draw_slide_tick(ax, run, k, color)
    count = N_AXIS_ARROWS
    if n_runs > MAX_PLAIN_RUNS:
        count = max(1, round(NUMBERED_AXIS_ARROWS / n_runs))
    _draw_axis_arrows(ax, run, (k + 0.5) / n_runs, color, count)
    ax.plot([x[0]], [y[0]], marker="o", markersize=4, color=color, zorder=6)
    return line


def _draw_straight(ax: Axes, run: RunData, color: str) -> None:
    """The straight line along the release velocity, from the release point to the end x.

    The line stops where it would leave the lane (y < 0 or y > lane width).
    """
    traj = run.trajectory
    p0, v0 = traj.position_m[0, :2], traj.velocity_mps[0, :2]
    if v0[0] <= 0.0:
        return
    slope = float(v0[1] / v0[0])
    x1 = float(traj.position_m[-1, 0])
    if slope != 0.0:
        y_edge = 0.0 if slope < 0.0 else float(run.plan.lane_width_m)
        x1 = min(x1, float(p0[0]) + (y_edge - float(p0[1])) / slope)
    if x1 <= p0[0]:
        return
    y1 = p0[1] + (x1 - p0[0]) * slope
    ax.plot([p0[0], x1], [p0[1], y1], color=color, lw=0.8, ls=(0, (4, 3)), alpha=0.7, zorder=3)


def _slide_point(run: RunData) -> tuple[float, float] | None:
    """(x, y) in m where the ball first starts rolling, or None if it never does."""
    slide = run.trajectory.summary.slide_m
    if slide is None:
        return None
    for ev in run.trajectory.events:
        if ev.kind == "slide_to_roll":
            return float(ev.x_m), float(ev.y_m)
    pos = run.trajectory.position_m
    return float(slide), float(np.interp(slide, pos[:, 0], pos[:, 1]))


def _draw_slide_tick(ax: Axes, run: RunData, k: int, color: str) -> None:
    """A tick mark across the path at the slide-to-roll point (gid ``slide_to_roll:k``)."""
    point = _slide_point(run)
    if point is None:
        return
    (tick,) = ax.plot(
        [point[0]],
        [point[1]],
        marker="|",
        markersize=16,
        markeredgewidth=2.2,
        color=color,
        linestyle="none",
        zorder=7,
    )
    tick.set_gid(f"slide_to_roll:{k}")


def _arc_length(pos: Array) -> Array:
    """Cumulative path length (m) of the (n, 2+) positions, starting at 0."""
    steps = np.linalg.norm(np.diff(pos[:, :2], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def axis_arrow_samples(
    run: RunData, phase: float = 0.5, count: int = N_AXIS_ARROWS
) -> tuple[Array, Array]:
    """Points and horizontal rotation-axis components for the arrows along ``run``'s path.

    Returns ``(points, uv)``: points, shape (k, 2) in m, on the path at arc lengths
    (i + phase) / count of its total length for i = 0 .. count - 1 (``phase`` in [0, 1)
    staggers several runs); uv, shape (k, 2), the x and y components of omega/|omega| there
    (dimensionless, length <= 1). Points where |omega| is zero are dropped.
    """
    traj = run.trajectory
    s = _arc_length(traj.position_m)
    if s[-1] <= 0.0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    targets = (np.arange(count) + phase) / count * s[-1]
    pts = np.column_stack([np.interp(targets, s, traj.position_m[:, i]) for i in range(2)])
    w = np.column_stack([np.interp(targets, s, traj.omega_radps[:, i]) for i in range(3)])
    norm = np.linalg.norm(w, axis=1)
    keep = norm > 1e-9
    uv = w[keep, :2] / norm[keep, None]
    return pts[keep], uv


def _draw_axis_arrows(
    ax: Axes, run: RunData, phase: float, color: str, count: int = N_AXIS_ARROWS
) -> None:
    """Quiver of ``count`` rotation-axis arrows in page coordinates (true angles; see
    runs_figure)."""
    pts, uv = axis_arrow_samples(run, phase, count)
    if pts.shape[0] == 0:
        return
    q = ax.quiver(
        pts[:, 0],
        pts[:, 1],
        uv[:, 0],
        uv[:, 1],
        angles="uv",
        scale_units="inches",
        scale=1.0 / AXIS_ARROW_IN,
        units="inches",
        width=0.022,
        headwidth=3.5,
        headlength=4.0,
        headaxislength=3.5,
        pivot="tail",
        color=color,
        zorder=6,
    )
    q.set_gid("omega_arrows")


def _run_label(run: RunData, *, short: bool = False) -> str:
    """Legend text: name, then slide, hook and pocket angle (or the outcome); ``short`` says
    "no roll" without "(slides to the end)"."""
    s = run.trajectory.summary
    no_roll = "no roll" if short else "no roll (slides to the end)"
    slide = no_roll if s.slide_m is None else f"slide {s.slide_m:.2f} m"
    if s.outcome == "pins" and s.hook_m is not None and s.pocket_deg is not None:
        result = f"hook {s.hook_m * 100:.0f} cm, pocket {s.pocket_deg:.1f}°"
    else:
        result = f"{s.outcome} at x = {s.x_end_m:.2f} m"
    return f"{run.name}: {slide}, {result}"


def _run_legend(fig: Figure, ax: Axes, handles: Sequence[Line2D]) -> Legend:
    """The legend of runs, one entry each, a fixed distance below the lane."""
    ncol = 1 if len(handles) > 4 else min(2, len(handles))
    below = offset_copy(ax.transAxes, fig=fig, y=-LEGEND_DROP_IN, units="inches")
    return ax.legend(
        handles=list(handles),
        loc="upper center",
        bbox_to_anchor=(0.5, 0.0),
        bbox_transform=below,
        ncols=ncol,
        fontsize=9,
        title_fontsize=8,
        frameon=False,
        handlelength=2.5,
    )


# --------------------------------------------------------------------------------------------
# many runs: colors and styles, numbers on the lane, the numbered legend

#: a path ending this close (m) to the lane end, or beyond it, is numbered beyond the lane end
_END_TOLERANCE_M = 0.01
#: CIELAB white point (D65) and the XYZ -> linear sRGB matrix
_D65 = np.array([0.95047, 1.0, 1.08883])
_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)


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


def _numbered_styles(n_runs: int) -> list[tuple[str, str]]:
    """(color, line style) of each of ``n_runs`` runs, no pair twice (see runs_figure).

    The colors cycle fastest, so runs next to each other in the list differ in color.
    """
    n_styles = min(len(NUMBERED_LINE_STYLES), math.ceil(n_runs / MAX_NUMBERED_COLORS))
    n_colors = math.ceil(n_runs / n_styles)
    colors = _perceptual_colors(n_colors)
    return [(colors[k % n_colors], NUMBERED_LINE_STYLES[k // n_colors]) for k in range(n_runs)]


def _reaches_end(run: RunData, length_m: float) -> bool:
    """True when ``run``'s path ends at (or beyond) the lane end ``length_m`` (m)."""
    return float(run.trajectory.position_m[-1, 0]) >= length_m - _END_TOLERANCE_M


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


def _number_runs(ax: Axes, runs: Sequence[RunData], box: _LaneBox, colors: Sequence[str]) -> None:
    """Number run k as k + 1 in its color, joined by a thin line to its path's end.

    Paths reaching the lane end are numbered in columns beyond it, alternating between the
    columns in order of the end's y and spread NUMBER_STEP_IN apart near their ends' heights;
    the others in the gutter strip on their side of the center line, spread
    NUMBER_GUTTER_STEP_IN apart along x.
    """
    ends = [
        (float(r.trajectory.position_m[-1, 0]), float(r.trajectory.position_m[-1, 1])) for r in runs
    ]
    at_end = sorted(
        (k for k, r in enumerate(runs) if _reaches_end(r, box.length_m)), key=lambda k: ends[k][1]
    )
    n_cols = box.number_columns(len(at_end))
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
                for k in range(len(runs))
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


def _numbered_legend(
    fig: Figure, ax: Axes, runs: Sequence[RunData], handles: Sequence[Line2D]
) -> Legend:
    """The legend of numbered runs ("k. " + the run's short text) a fixed distance below the
    lane, in as many balanced columns as fit in NUMBERED_LEGEND_WIDTH_IN; the figure is made
    taller to hold it."""
    labels = [f"{k + 1}. {_run_label(run, short=True)}" for k, run in enumerate(runs)]
    below = offset_copy(ax.transAxes, fig=fig, y=-LEGEND_DROP_IN, units="inches")
    fontsize = 8.0
    column_gap_in = 2.0 * fontsize / 72.0

    def legend(ncols: int) -> Legend:
        return ax.legend(
            handles=list(handles),
            labels=labels,
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


def _symbol_key(ax: Axes, *, numbered: bool = False) -> None:
    """A key of the symbols, above the lane's upper right corner (with the head pin and the
    run numbers if ``numbered``)."""
    key = (
        "|  start of rolling     - - -  straight line along the release velocity     "
        "→  horizontal part of ω/|ω| (true angle)"
    )
    if numbered:
        key = (
            "|  start of rolling    - - -  straight line along the release velocity    "
            "→  horizontal part of ω/|ω| (true angle)    ○  head pin    1, 2, …  runs"
        )
    ax.text(
        1.0,
        1.015,
        key,
        transform=ax.transAxes,
        fontsize=8,
        ha="right",
        va="bottom",
        color="#333333",
    )


def _lane_title(ax: Axes, runs: Sequence[RunData], title: str | None) -> None:
    """The given title, or the runs' names."""
    if title is None:
        names = [r.name for r in runs]
        title = ", ".join(names) if len(names) <= 4 else f"{names[0]} and {len(names) - 1} more"
    ax.set_title(title, fontsize=12, pad=18)


def _lanes_differ(runs: Sequence[RunData]) -> bool:
    """True when some run's lane size or friction map differs from the first run's."""
    first = runs[0].plan
    ref = (first.lane_length_m, first.lane_width_m)
    cells = friction_cells(first)
    return any(
        (r.plan.lane_length_m, r.plan.lane_width_m) != ref or friction_cells(r.plan) != cells
        for r in runs[1:]
    )


# --------------------------------------------------------------------------------------------
# the time-series figure

_SERIES = (
    ("speed_mps", "speed (m/s)"),
    ("rev_rate_rpm", "rev rate (rpm)"),
    ("slip_speed_mps", "slip speed (m/s)"),
    ("mu", "friction μ"),
)


def series_figure(run: RunData, *, title: str | None = None) -> Figure:
    """Speed (m/s), rev rate (rpm), slip speed (m/s) and mu against time (s) for ``run``.

    Four panels share the time axis; rolling intervals (phase 1) are shaded light green and
    each event is a dashed vertical line across all panels (gid ``event:<kind>``), colored by
    kind with a legend of the kinds that occur (the run's end event in black). The title is the
    run's legend text of :func:`runs_figure` (name, slide, hook, pocket angle or outcome)
    unless ``title`` is given. Raises :class:`~bowlrec.sinks.SamplesRequiredError` for a
    summary-only run.
    """
    run.require_samples("plot")
    traj = run.trajectory
    cols = series_columns(traj)
    fig = Figure(figsize=(10.0, 8.0), layout="constrained")
    axes = fig.subplots(len(_SERIES), 1, sharex=True)
    for ax, (key, label) in zip(axes, _SERIES, strict=True):
        values = cols[key][0]
        ax.plot(traj.t_s, values, color=_RUN_COLORS[0], lw=1.5)
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
    fig.suptitle(title if title is not None else _run_label(run), fontsize=11)
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
        ax.axvspan(t0, t1, color="#1b8a3a", alpha=0.08, lw=0, zorder=0)


def _event_color(kind: str) -> str:
    """Line color of an event kind (end-of-run kinds are black)."""
    return _EVENT_COLORS.get(kind, _END_EVENT_COLOR)


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
        handles.append(Rectangle((0, 0), 1, 1, color="#1b8a3a", alpha=0.15, label="rolling"))
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=9)
