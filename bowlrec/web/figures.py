"""Figures for the web pages, as file bytes (SVG or PNG).

Every function is pure: it takes runs, a pattern, numbers or a ball and returns the bytes of one
figure. matplotlib (a :class:`~matplotlib.figure.Figure` on an Agg canvas, never pyplot) is imported
inside the functions, so importing this module does not import it. SVG output is deterministic:
a fixed ``svg.hashsalt``, no date or creator metadata and text as paths, so the same input gives
the same bytes. PNG output is rendered at :data:`PNG_DPI` dots per inch.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from bowlrec.bowling.layout import PAP, Layout
    from bowlrec.bowling.oil import KegelPattern, RectanglePattern
    from bowlrec.sinks.common import RunData

__all__ = [
    "PNG_DPI",
    "ball_figure",
    "compare_figure",
    "pattern_figure",
    "run_figure",
    "sweep_figure",
]

Format = Literal["svg", "png"]

#: resolution of PNG figures (dots per inch)
PNG_DPI = 100
#: the salt of the ids matplotlib writes into SVG (fixed so the output is reproducible)
SVG_HASHSALT = "bowlrec"
#: distances down the lane (ft) of the cross-lane oil curves, kept where there is oil
PATTERN_DISTANCES_FT = (2.0, 10.0, 20.0, 30.0, 36.0, 40.0, 44.0)


def _render(fig: Figure, fmt: Format) -> bytes:
    """The bytes of ``fig`` as SVG or PNG, tightly cropped; SVG reproducibly."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if fmt not in ("svg", "png"):
        raise ValueError(f"fmt = {fmt!r} must be 'svg' or 'png'")
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    rc: dict[Any, Any] = {
        "svg.hashsalt": SVG_HASHSALT,
        "svg.fonttype": "path",
        "svg.image_inline": True,
    }
    with matplotlib.rc_context(rc):
        metadata = {"Date": None, "Creator": None} if fmt == "svg" else {"Software": None}
        fig.savefig(
            buf,
            format=fmt,
            dpi=PNG_DPI,
            bbox_inches="tight",
            pad_inches=0.15,
            metadata=metadata,
        )
    return buf.getvalue()


def run_figure(run: RunData, fmt: Format) -> bytes:
    """The paper-style lane figure of one run (what ``bowlrec plot`` draws: lane, oil, path,
    release line, start of rolling, rotation axes; :func:`bowlrec.sinks.plot.runs_figure`).

    Raises :class:`~bowlrec.errors.SamplesRequiredError` for a run without samples.
    """
    return compare_figure([run], fmt)


def compare_figure(runs: Sequence[RunData], fmt: Format) -> bytes:
    """Several runs overlaid on the first run's lane (:func:`bowlrec.sinks.plot.runs_figure`:
    one color each up to eight runs, numbered paths beyond).

    Raises ValueError for no runs and :class:`~bowlrec.errors.SamplesRequiredError` for a run
    without samples.
    """
    from bowlrec.sinks.plot import runs_figure

    return _render(runs_figure(runs), fmt)


def pattern_figure(
    pattern: KegelPattern | RectanglePattern, fmt: Format, *, title: str | None = None
) -> bytes:
    """An oil pattern as a pattern sheet draws it, in three panels over boards 1..39 (counted
    from the right gutter, as a right-hander counts them; the L/R notation of a sheet is
    absolute):

    * a board x distance map of the oil density (µL per board per ft; y: ft from the foul line
      to the end of the laid oil);
    * cross-lane curves: the oil density (µL per board per ft) on each board at several
      distances (ft) inside the oil (:data:`PATTERN_DISTANCES_FT`);
    * the oil per board over the whole pattern (µL per board, Kegel's composite graph), with the
      total volume (mL) and the ratio (boards 18..22 over 3..7 and 33..37) in the title.

    The oil stays where the machine lays it (no buffing or carrydown; :mod:`bowlrec.bowling.oil`).
    """
    import numpy as np
    from matplotlib.figure import Figure

    from bowlrec.bowling.oil import board_volumes_ul, oil_grid, ratio
    from bowlrec.units import BOARDS

    grid = oil_grid(pattern)
    end_ft = max(grid.oil_end_ft, 1.0)
    boards = np.arange(1, BOARDS + 1)
    heights = np.diff(grid.x_edges_ft)
    rows = [
        board_volumes_ul(grid, float(x0) + 0.5 * float(h))
        for x0, h in zip(grid.x_edges_ft[:-1], heights, strict=True)
    ]
    density = np.array(rows) if rows else np.zeros((1, BOARDS))
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    ax_map, ax_cross, ax_total = fig.subplots(1, 3, width_ratios=(1.0, 1.3, 1.3))

    edges_x = np.arange(0.5, BOARDS + 1.0)
    edges_y = np.asarray(grid.x_edges_ft, dtype=np.float64)
    if edges_y.size < 2:
        edges_y = np.array([0.0, end_ft])
    mesh = ax_map.pcolormesh(edges_x, edges_y, density, cmap="YlOrBr", shading="flat")
    cbar = fig.colorbar(mesh, ax=ax_map, label="oil (µL per board per ft)", shrink=0.9)
    if cbar.solids is not None:
        cbar.solids.set_rasterized(False)  # vector SVG, no embedded raster
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
    ax_total.bar(boards, totals, width=0.85, color="#b07a2a")
    ax_total.set_xlim(0.5, BOARDS + 0.5)
    ax_total.set_xlabel("board")
    ax_total.set_ylabel("oil over the pattern (µL per board)")
    r = ratio(grid)
    ratio_text = "ratio undefined" if r is None else f"ratio {r:.2f}:1"
    volume_ml = float(np.sum(grid.volume_ul)) / 1000.0
    ax_total.set_title(f"oil per board: {volume_ml:.2f} mL, {ratio_text}", fontsize=10)
    ax_total.grid(True, axis="y", color="#dddddd", lw=0.6)
    for ax in (ax_map, ax_cross, ax_total):
        ax.set_xticks([1, 5, 10, 15, 20, 25, 30, 35, 39])
    name = getattr(pattern, "name", None) or "oil pattern"
    fig.suptitle(title if title is not None else f"{name}: oil laid to {grid.oil_end_ft:g} ft")
    return _render(fig, fmt)


def sweep_figure(
    x: Sequence[float],
    y: Sequence[float | None],
    *,
    x_label: str,
    y_label: str,
    title: str | None = None,
    fmt: Format,
) -> bytes:
    """A swept metric ``y`` against a swept parameter ``x`` (labels carry the units): the points
    marked and joined in increasing x; points whose y is None or NaN (or whose x is not
    finite) are left out. Raises ValueError if ``x`` and ``y`` differ in length."""
    from matplotlib.figure import Figure

    if len(x) != len(y):
        raise ValueError(f"x has {len(x)} values but y has {len(y)}")
    points = sorted(
        (float(a), float(b))
        for a, b in zip(x, y, strict=True)
        if b is not None and math.isfinite(float(b)) and math.isfinite(float(a))
    )
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.subplots()
    if points:
        xs, ys = zip(*points, strict=True)
        ax.plot(xs, ys, "-o", color="#1f4e9c", lw=1.5, ms=4)
    else:
        ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center", va="center")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.grid(True, color="#dddddd", lw=0.6)
    if title is not None:
        ax.set_title(title, fontsize=11)
    return _render(fig, fmt)


def ball_figure(
    entry_or_ball: Any,
    fmt: Format,
    *,
    layout: Layout | None = None,
    pap: PAP | None = None,
) -> bytes | None:
    """The layout of a bowler's spec-sheet ball, or None for any other ball.

    ``entry_or_ball``: a library :class:`~bowlrec.archive.balls.BallEntry` or a ball. A spec
    sheet (:class:`~bowlrec.bowling.ball.BowlerBall`) carries no layout, so one must be given
    (``layout``, with ``pap``; default PAP 5 in over, 0.5 in up, a right-hander's): the figure
    is None without it. Drawn: the ball's surface seen from outside the grip, as an azimuthal
    equidistant map centered on the center of grip (distances from it along the surface in
    inches, x: the layout sheet's right, y: toward the fingers), with the center of grip, the
    PAP, the pin (low-RG axis) and the PSA (high-RG axis, for an asymmetric core) as
    :func:`bowlrec.bowling.layout.grip_axes` places them, the track-side great circle 90 deg
    from the PAP and the circle where the map's edge lies (the equator of the grip).
    """
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.bowling.layout import PAP, grip_axes

    ball = getattr(entry_or_ball, "ball", entry_or_ball)
    if not isinstance(ball, BowlerBall) or layout is None:
        return None
    import numpy as np
    from matplotlib.figure import Figure

    pap_spec = pap if pap is not None else PAP(over_in=5.0, up_in=0.5)
    axes = grip_axes(ball, layout, pap_spec)
    r = float(ball.radius_in)

    def mapped(v: Any) -> tuple[float, float]:
        u = np.asarray(v, dtype=np.float64)
        u = u / float(np.linalg.norm(u))
        theta = math.acos(max(-1.0, min(1.0, float(u[2]))))
        rho = math.hypot(float(u[0]), float(u[1]))
        if rho == 0.0:
            return (0.0, 0.0)
        return (r * theta * float(u[0]) / rho, r * theta * float(u[1]) / rho)

    fig = Figure(figsize=(5.2, 5.2), layout="constrained")
    ax = fig.subplots()
    t = np.linspace(0.0, 2.0 * math.pi, 181)
    edge = r * math.pi / 2.0
    ax.plot(edge * np.cos(t), edge * np.sin(t), color="#999999", lw=0.8, ls=":")
    p = np.asarray(axes.pap, dtype=np.float64)
    e1 = np.cross(p, [0.0, 0.0, 1.0] if abs(p[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(p, e1)
    track = [mapped(math.cos(a) * e1 + math.sin(a) * e2) for a in t]
    front = [(tx, ty) for tx, ty in track if math.hypot(tx, ty) <= edge + 1e-9]
    if front:
        ax.plot(*zip(*front, strict=True), ".", ms=1.5, color="#c0282d", label="90° from the PAP")
    marks: list[tuple[str, Any, str, str]] = [
        ("center of grip", (0.0, 0.0, 1.0), "#222222", "+"),
        ("PAP", axes.pap, "#c0282d", "o"),
        ("pin", axes.pin, "#1f4e9c", "o"),
    ]
    if ball.core_type != "symmetric":
        marks.append(("PSA", axes.psa, "#1b8a3a", "s"))
    for label, vec, color, marker in marks:
        mx, my = mapped(vec)
        ax.plot([mx], [my], marker, color=color, ms=8, label=label)
        ax.annotate(label, (mx, my), xytext=(5, 5), textcoords="offset points", fontsize=8)
    lim = r * math.pi * 0.75
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.set_xlabel("along the surface, layout sheet's right (in)")
    ax.set_ylabel("along the surface, toward the fingers (in)")
    ax.grid(True, color="#eeeeee", lw=0.6)
    ax.legend(fontsize=7, loc="lower right", frameon=False)
    ax.set_title(f"{ball.name}: layout, {pap_spec.handedness}-handed", fontsize=10)
    return _render(fig, fmt)
