"""A bowler's ball and its layout: the surface around the grip, with the center of grip, the
PAP, the pin and the PSA where the layout puts them (the web page's ball library)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

from bowlrec.bowling.ball import BowlerBall
from bowlrec.bowling.layout import PAP, grip_axes

from .render import new_figure

if TYPE_CHECKING:
    from bowlrec.bowling.layout import Layout

__all__ = ["DEFAULT_PAP", "ball_figure"]

#: the PAP a layout is drawn for unless another is given: 5 in over, 0.5 in up, a right-hander's
DEFAULT_PAP = PAP(over_in=5.0, up_in=0.5)


def ball_figure(
    entry_or_ball: Any, *, layout: Layout | None = None, pap: PAP | None = None
) -> Figure | None:
    """The layout of a bowler's spec-sheet ball, or None for any other ball.

    ``entry_or_ball``: a ball, or what carries one as ``.ball`` (a library entry). A spec
    sheet (:class:`~bowlrec.bowling.ball.BowlerBall`) carries no layout, so one must be given
    (``layout``, with ``pap``; default :data:`DEFAULT_PAP`): the figure is None without it.
    Drawn: the ball's surface seen from outside the grip, as an azimuthal equidistant map
    centered on the center of grip (distances from it along the surface in inches, x: the
    layout sheet's right, y: toward the fingers), with the center of grip, the PAP, the pin
    (low-RG axis) and the PSA (high-RG axis, for an asymmetric core) as
    :func:`bowlrec.bowling.layout.grip_axes` places them, the track-side great circle 90 deg
    from the PAP and the circle where the map's edge lies (the equator of the grip).
    """
    ball = getattr(entry_or_ball, "ball", entry_or_ball)
    if not isinstance(ball, BowlerBall) or layout is None:
        return None
    pap_spec = pap if pap is not None else DEFAULT_PAP
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

    fig = new_figure(figsize=(5.2, 5.2), layout="constrained")
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
    return fig
