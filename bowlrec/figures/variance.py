"""Release variance at the pins (``bowlrec aim variance --plot``, ``bowlrec aim tolerance
--plot``): where a bowler's repeats of a shot enter, and the tolerance map of a shot (entry
board over target board at the arrows x release speed), each with the pocket window.

These figures are written at their own size and resolution (7 x 4.5 in at 120 dots per inch,
laid out tightly inside; :data:`SAVE`), not cropped.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from bowlrec.bowling.report import board_count
from bowlrec.spec._base import fmt

from .render import new_figure, save_figure

if TYPE_CHECKING:
    from bowlrec.bowling.variance import ScatterResult, ToleranceMap

__all__ = [
    "SAVE",
    "scatter_figure",
    "tolerance_figure",
    "write_scatter_figure",
    "write_tolerance_figure",
]

#: the page of these figures: size (in) and resolution (dots per inch)
FIGSIZE_IN = (7.0, 4.5)
DPI = 120
#: how they are written: at the figure's own resolution, uncropped
SAVE: dict[str, Any] = {"dpi": None, "tight": False}


def scatter_figure(result: ScatterResult, title: str = "") -> Figure:
    """Entry angle against entry board of every repeat, the pocket window drawn, with the
    shares in the title."""
    p = result.pocket
    fig = new_figure(figsize=FIGSIZE_IN, dpi=DPI)
    ax = fig.subplots()
    ok = result.in_pocket
    b, a = result.entry_board, result.entry_angle_deg
    ax.scatter(b[~ok], a[~ok], s=4, alpha=0.5, color="tab:gray", label="outside the pocket")
    ax.scatter(b[ok], a[ok], s=4, alpha=0.6, color="tab:green", label="in the pocket window")
    ax.add_patch(
        Rectangle(
            (p.board_min, p.angle_min_deg), p.board_max - p.board_min,
            p.angle_max_deg - p.angle_min_deg, fill=False, edgecolor="tab:green", lw=1.5,
        )
    )  # fmt: skip
    ax.set_xlabel(f"entry board at the head pin line ({board_count(result.handedness)})")
    ax.set_ylabel("entry angle (deg)")
    ax.invert_xaxis()
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    head = f"{title}: " if title else ""
    ax.set_title(
        f"{head}{100 * result.pocket_share:.1f} % in the pocket "
        f"(± {100 * result.pocket_share_se:.1f}), {100 * result.pins_share:.1f} % reach the "
        f"pins, n = {result.n}",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def tolerance_figure(tmap: ToleranceMap, title: str = "") -> Figure:
    """The entry board over target x speed with the pocket window's board limits (solid) and
    angle limits (dashed) as contours and the scene's shot marked."""
    fig = new_figure(figsize=FIGSIZE_IN, dpi=DPI)
    ax = fig.subplots()
    mesh = ax.pcolormesh(
        tmap.targets, tmap.speeds_mph, tmap.entry_board, cmap="coolwarm", shading="nearest",
        vmin=tmap.pocket.board - 8.0, vmax=tmap.pocket.board + 8.0,
    )  # fmt: skip
    fig.colorbar(mesh, ax=ax, label=f"entry board ({board_count(tmap.handedness)})")
    p = tmap.pocket
    board = np.ma.masked_invalid(tmap.entry_board)
    angle = np.ma.masked_invalid(tmap.entry_angle_deg)
    if board.count() > 3:
        ax.contour(tmap.targets, tmap.speeds_mph, board, levels=[p.board_min, p.board_max],
                   colors="black", linewidths=1.2)  # fmt: skip
    if angle.count() > 3:
        cs = ax.contour(tmap.targets, tmap.speeds_mph, angle,
                        levels=[p.angle_min_deg, p.angle_max_deg], colors="dimgray",
                        linestyles="dashed", linewidths=1.0)  # fmt: skip
        ax.clabel(cs, fmt="%g deg", fontsize=7)
    ax.plot([tmap.scene_target], [tmap.scene_speed_mph], "k*", ms=12, label="the scene's shot")
    ax.set_xlabel(f"target board at the arrows ({board_count(tmap.handedness)})")
    ax.set_ylabel("release speed (mph)")
    ax.invert_xaxis()
    ax.legend(loc="upper right", fontsize=8)
    d = tmap.to_dict()
    tr, sr = d["target_range_at_scene_speed"], d["speed_range_at_scene_target"]
    span = f"target {tr[0]:.2f}-{tr[1]:.2f}" if tr else "no target"
    speed = f"{sr[0]:.2f}-{sr[1]:.2f} mph" if sr else "no speed"
    head = f"{title}: " if title else ""
    ax.set_title(
        f"{head}entry boards {fmt(p.board_min)}-{fmt(p.board_max)} between the solid lines, "
        f"entry angle dashed\nin the window: {span} at its speed, {speed} at its target",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def write_scatter_figure(
    result: ScatterResult, path: str | os.PathLike[str], *, title: str = ""
) -> Path:
    """Write :func:`scatter_figure` to ``path`` (.png or .svg); return the path."""
    return save_figure(scatter_figure(result, title), path, **SAVE)


def write_tolerance_figure(
    tmap: ToleranceMap, path: str | os.PathLike[str], *, title: str = ""
) -> Path:
    """Write :func:`tolerance_figure` to ``path`` (.png or .svg); return the path."""
    return save_figure(tolerance_figure(tmap, title), path, **SAVE)
