"""The paper-style figure of finished runs: ball paths over the lane and its oil pattern, in the
style of Frohlich (2004), Figs. 1 and 4-6.

:func:`runs_figure` builds the figure (for notebooks, tests and the web pages);
:func:`plot_runs` writes it as PNG or SVG, and :func:`write_plot` is the PNG/SVG writer of
:mod:`bowlrec.sinks.registry` (one run). The lane is drawn by :mod:`bowlrec.figures.lane`; more
than :data:`MAX_PLAIN_RUNS` runs are numbered (:mod:`bowlrec.figures.numbered`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.transforms import offset_copy
from numpy.typing import NDArray

from bowlrec.spec.run import friction_cells

from .lane import AXES_WIDTH_IN, LaneBox, draw_friction, draw_lane_marks, lane_axes
from .numbered import (
    number_runs,
    numbered_legend,
    numbered_styles,
    numbers_strip_in,
    reaches_end,
)
from .render import format_for, save_figure

if TYPE_CHECKING:
    from bowlrec.spec.run import RunData

__all__ = [
    "MAX_PLAIN_RUNS",
    "N_AXIS_ARROWS",
    "PAPER_EXAGGERATION",
    "PNG_DPI",
    "RUN_COLORS",
    "axis_arrow_samples",
    "plot_runs",
    "run_label",
    "runs_handedness",
    "runs_figure",
    "write_plot",
]

Array = NDArray[np.float64]

#: the paper's exaggeration of the lane width in its trajectory figures (Fig. 1 caption)
PAPER_EXAGGERATION = 4.5
#: the largest lane-width exaggeration drawn: beyond it the lane outgrows any figure
MAX_EXAGGERATION = 100.0
#: number of rotation-axis arrows drawn along each path
N_AXIS_ARROWS = 10
#: rotation-axis arrows drawn in all in a numbered figure (at least one per run)
NUMBERED_AXIS_ARROWS = 40
#: length on the page (inches) of a rotation-axis arrow whose omega is horizontal
AXIS_ARROW_IN = 0.25
#: distance (inches) from the lane's lower edge down to the legend (room for the x label)
LEGEND_DROP_IN = 0.55
#: up to this many runs get the plain figure (one color each, legend of full-width entries);
#: more runs are numbered (see runs_figure)
MAX_PLAIN_RUNS = 8
#: resolution of the PNG files :func:`plot_runs` writes (dots per inch)
PNG_DPI = 150
#: run colors, chosen to stand out on the tan lane (no browns or oranges)
RUN_COLORS = (
    "#1f4e9c",
    "#c0282d",
    "#1b8a3a",
    "#7b3fa0",
    "#0a8a99",
    "#d4458f",
    "#222222",
    "#5c6bc0",
)


# --------------------------------------------------------------------------------------------
# writing


def plot_runs(
    runs: Sequence[RunData],
    path: str | os.PathLike[str],
    *,
    exaggerate: float | None = None,
    title: str | None = None,
) -> Path:
    """Write the paper-style lane figure of ``runs`` to ``path`` (.png or .svg); return the path.

    See :func:`runs_figure` for what is drawn. PNG at :data:`PNG_DPI` dots per inch; the file
    is written atomically (:func:`bowlrec.figures.render.save_figure`). Raises ValueError for
    another suffix, for no runs, and :class:`~bowlrec.errors.SamplesRequiredError` for a
    summary-only run.
    """
    format_for(path)  # a bad suffix is refused before anything is drawn
    fig = runs_figure(runs, exaggerate=exaggerate, title=title)
    return save_figure(fig, path, dpi=PNG_DPI)


def write_plot(run: RunData, path: str | os.PathLike[str]) -> Path:
    """:func:`plot_runs` of the one run ``run`` (the registry's writer)."""
    return plot_runs([run], path)


# --------------------------------------------------------------------------------------------
# the lane figure


def runs_figure(
    runs: Sequence[RunData],
    *,
    exaggerate: float | None = None,
    title: str | None = None,
) -> Figure:
    """The lane figure of ``runs`` as a :class:`~matplotlib.figure.Figure` (not written).

    Axes: x is the distance from the foul line toward the pins (m, horizontal); y is the
    distance from the right gutter toward the left (m on the left axis, the lane frame; boards
    in the bowler's count on the right axis, from the right gutter, or from the left one when
    every run is a left-hander's; a lane has 39 boards), so a ball hooking left goes up. The
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
    (cm) and pocket angle (deg) as magnitudes with their side named ("to the left": +y), or
    the outcome when the ball does not reach the pins. The board axis counts boards as the
    bowler does, from the bowling hand's gutter (:func:`runs_handedness`), and says so.

    Up to MAX_PLAIN_RUNS runs, each has its own color from a fixed palette and the legend sits
    below the lane. More runs are numbered 1, 2, ... in order
    (:mod:`bowlrec.figures.numbered`): the paths cycle through evenly spaced hues of one
    CIELAB lightness (dark against the lane, skipping its tans) and, past
    MAX_NUMBERED_COLORS colors, through the line styles NUMBERED_LINE_STYLES, so no two
    runs share both color and style. Each path carries its number (gid ``run_number:k``,
    joined to the path's end by a thin line): paths that reach the end of the lane are numbered
    in columns beyond it, the others in the gutter strip on the side where they end. The
    legend entries start with the numbers and fill as many columns as fit under the lane; the
    figure grows in height with the legend, so the lane keeps the size it has for a few runs
    (it is drawn a little shorter only when the numbers need more than the two columns that
    fit beyond the lane end, about 40 runs that reach the pins). The head pin's label moves to
    the symbol key.

    Raises ValueError if ``runs`` is empty or ``exaggerate`` is not in (0,
    :data:`MAX_EXAGGERATION`], and
    :class:`~bowlrec.errors.SamplesRequiredError` for a summary-only run.
    """
    if len(runs) == 0:
        raise ValueError("plot needs at least one run")
    for run in runs:
        run.require_samples("plot")
    ex = PAPER_EXAGGERATION if exaggerate is None else float(exaggerate)
    if not 0.0 < ex <= MAX_EXAGGERATION:  # NaN fails too
        raise ValueError(
            f"exaggerate = {exaggerate!r} must be in (0, {MAX_EXAGGERATION:g}] (the paper's: "
            f"{PAPER_EXAGGERATION:g})"
        )

    numbered = len(runs) > MAX_PLAIN_RUNS
    box = _lane_box(runs, ex, numbered=numbered)
    fig, ax = lane_axes(box, runs_handedness(runs))
    draw_friction(fig, ax, friction_cells(runs[0].plan))
    draw_lane_marks(ax, box, pin_label=not numbered)
    if numbered:
        styles = numbered_styles(len(runs))
    else:
        styles = [(RUN_COLORS[k % len(RUN_COLORS)], "-") for k in range(len(runs))]
    handles: list[Line2D] = []
    for k, (run, (color, style)) in enumerate(zip(runs, styles, strict=True)):
        handles.append(_draw_run(ax, run, k, len(runs), color, style))
    if numbered:
        number_runs(ax, [_end(r) for r in runs], box, [color for color, _ in styles])
        labels = [f"{k + 1}. {run_label(run, short=True)}" for k, run in enumerate(runs)]
        legend = numbered_legend(fig, ax, labels, handles, LEGEND_DROP_IN)
    else:
        legend = _run_legend(fig, ax, handles)
    if _lanes_differ(runs):
        legend.set_title(f"lane and oil pattern drawn: those of {runs[0].name} (the lanes differ)")
    _symbol_key(ax, numbered=numbered)
    _lane_title(ax, runs, title)
    return fig


def _end(run: RunData) -> tuple[float, float]:
    """(x, y) in m where ``run``'s path ends."""
    end = run.trajectory.position_m[-1]
    return float(end[0]), float(end[1])


def _lane_box(runs: Sequence[RunData], ex: float, *, numbered: bool = False) -> LaneBox:
    """The first run's lane, with axes limits that hold every path, the head pin and gutters.

    Gutters are drawn GUTTER_PAGE_IN high on the page whatever the exaggeration. With
    ``numbered``, the space beyond the lane end is widened when the run numbers placed there
    (:func:`bowlrec.figures.numbered.number_runs`) need more columns than it holds.
    """
    length = float(runs[0].plan.lane_length_m)
    width = float(runs[0].plan.lane_width_m)
    ys = np.concatenate([r.trajectory.position_m[:, 1] for r in runs])
    xs = np.concatenate([r.trajectory.position_m[:, 0] for r in runs])
    x0 = min(-0.5, float(xs.min()) - 0.2)
    x1 = max(length + 0.9, float(xs.max()) + 0.3)
    box = LaneBox.fitting(length, width, ex, (x0, x1), ys)
    if not numbered:
        return box
    n_end = sum(reaches_end(_end(r)[0], length) for r in runs)
    for _ in range(8):  # a wider strip shrinks the scale, so a column holds fewer numbers
        share = numbers_strip_in(box, n_end) / AXES_WIDTH_IN
        needed = (length - share * x0) / (1.0 - share)  # solves x1 - length = share * (x1 - x0)
        if needed <= box.x_lim[1] + 1e-9:
            break
        box = LaneBox.fitting(length, width, ex, (x0, needed), ys)
    return box


# --------------------------------------------------------------------------------------------
# one run: path, release line, start of rolling, rotation axes


def _draw_run(ax: Axes, run: RunData, k: int, n_runs: int, color: str, style: str = "-") -> Line2D:
    """Path (in line style ``style``), straight reference, slide-to-roll tick and omega arrows
    of run ``k``; the path."""
    traj = run.trajectory
    x, y = traj.position_m[:, 0], traj.position_m[:, 1]
    (line,) = ax.plot(x, y, color=color, ls=style, lw=1.8, zorder=5, label=run_label(run))
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


# --------------------------------------------------------------------------------------------
# legend, key and title


def runs_handedness(runs: Sequence[RunData]) -> str:
    """Whose count the board axis uses: "left" when every run's path is a left-hander's
    (:func:`~bowlrec.bowling.report.inferred_handedness`), else "right"."""
    from bowlrec.bowling.report import inferred_handedness

    hands = {inferred_handedness(r.trajectory.position_m[:, 1]) for r in runs}
    return "left" if hands == {"left"} else "right"


def run_label(run: RunData, *, short: bool = False) -> str:
    """Legend text: name, then slide, hook and pocket angle (or the outcome); ``short`` says
    "no roll" without "(slides to the end)"."""
    s = run.trajectory.summary
    no_roll = "no roll" if short else "no roll (slides to the end)"
    slide = no_roll if s.slide_m is None else f"slide {s.slide_m:.2f} m"
    if s.outcome == "pins" and s.hook_m is not None and s.pocket_deg is not None:
        from bowlrec.bowling.sides import sideways

        hook = sideways(100.0 * s.hook_m, ".0f", "cm")
        result = f"hook {hook}, pocket {sideways(s.pocket_deg, '.1f', '°')}"
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
