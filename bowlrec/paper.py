"""Frohlich (2004), Table III: the paper's 18 simulated deliveries and its printed results.

Facts common to every case: V0 = 8.0 m/s of the geometric center, |omega0| = 30 rad/s,
R = 0.1085 m, g = 9.81 m/s^2, a 42 in (1.0668 m) by 60 ft (18.288 m) lane, release at x = 0
on the lane center (y = 0.5334 m). The paper gives no mass; 6.8 kg is used (the kinematics do not
depend on it). Offsets are given as ``com_offset_m`` (center -> center of mass): "offset parallel
to omega0" means the center of mass displaced along +omega0 (the paper's r_Delta is its
negative).

Two variants: ``"as_written"`` follows the paper's text (oil over the first 40 ft = 12.192 m);
``"best_fit"`` uses oil to 12.70 m and releases case 8 at y = 0.40 m, which reproduces the
printed numbers more closely.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from bowlrec.spec import (
    Ball,
    ConstantFriction,
    Delivery,
    Lane,
    Options,
    Scene,
    TypicalFriction,
    dump_scene_json,
)

__all__ = ["TABLE_III", "PaperCase", "Variant", "paper_scene", "write_paper_examples"]

Variant = Literal["as_written", "best_fit"]

_SPEED_MPS = 8.0
_OMEGA_RADPS = 30.0
_RADIUS_M = 0.1085
_MASS_KG = 6.8
_G_MPS2 = 9.81
_LANE_LENGTH_M = 18.288
_LANE_WIDTH_M = 1.0668
_BEST_FIT_OIL_LENGTH_M = 12.70
_BEST_FIT_CASE8_Y0_M = 0.40

_S35, _C35 = math.sin(math.radians(35.0)), math.cos(math.radians(35.0))
_S15, _C15 = math.sin(math.radians(15.0)), math.cos(math.radians(15.0))
_S75, _C75 = math.sin(math.radians(75.0)), math.cos(math.radians(75.0))

_FORWARD = (0.0, _OMEGA_RADPS, 0.0)
_SIDEWAYS = (-_OMEGA_RADPS, 0.0, 0.0)
#: cases 9-18: 35 deg to the rear of left, inclined 15 deg above horizontal
_COMBINATION = (-_OMEGA_RADPS * _C15 * _S35, _OMEGA_RADPS * _C15 * _C35, _OMEGA_RADPS * _S15)
#: cases 9-18: the long (low-RG) axis, horizontal, 35 deg to the rear of left
_A_LONG = (-_S35, _C35, 0.0)


@dataclass(frozen=True)
class PaperCase:
    """One row of Table III: the inputs (SI) and the printed results."""

    case: int
    #: take-off angle (deg), positive toward the left
    toa_deg: float
    #: radii of gyration about (a_long, the two others) (m)
    rg_m: tuple[float, float, float]
    #: direction of principal axis 1 (a_long) in the lane frame at release
    axis_1: tuple[float, float, float]
    #: center -> center of mass (m), lane frame at release
    com_offset_m: tuple[float, float, float]
    omega_radps: tuple[float, float, float]
    #: "typical" or a constant mu
    friction: float | Literal["typical"]
    #: printed slide distance (m); None for "to pins" (the ball never rolls)
    slide_m: float | None
    #: printed hook, the leftward deflection from a straight path (m)
    hook_m: float
    #: printed pocket angle (deg)
    pocket_deg: float
    #: the table row in words
    row: str


def _row(
    case: int,
    toa: float,
    rg_cm: tuple[float, float, float],
    axis_1: tuple[float, float, float],
    offset: tuple[float, float, float],
    omega: tuple[float, float, float],
    friction: float | Literal["typical"],
    printed: tuple[float | None, float, float],
    row: str,
) -> PaperCase:
    slide, hook_cm, pocket = printed
    return PaperCase(
        case=case,
        toa_deg=toa,
        rg_m=(rg_cm[0] / 100.0, rg_cm[1] / 100.0, rg_cm[2] / 100.0),
        axis_1=axis_1,
        com_offset_m=offset,
        omega_radps=omega,
        friction=friction,
        slide_m=slide,
        hook_m=hook_cm / 100.0,
        pocket_deg=pocket,
        row=row,
    )


_X = (1.0, 0.0, 0.0)
_NO = (0.0, 0.0, 0.0)
_OFF_LONG = (0.0007 * _A_LONG[0], 0.0007 * _A_LONG[1], 0.0)
_RG62, _RG62N = (6.2, 6.2, 6.2), (6.2, 6.4, 6.4)
_RG71, _RG69N = (7.1, 7.1, 7.1), (6.9, 7.1, 7.1)
_FWD = "forward rotation (omega0 horizontal toward left)"
_SIDE = "sideways rotation (omega0 horizontal toward rear)"
_COMBO = (
    "combination: omega0 35 deg to rear of left, inclined 15 deg above horizontal; "
    "a_long horizontal, 35 deg to rear of left"
)

#: Table III, cases 1..18 (index = case - 1)
TABLE_III: tuple[PaperCase, ...] = (
    _row(1, 0.0, (6.7,) * 3, _X, _NO, _FORWARD, 0.12, (8.10, 0, 0.0),
         f"{_FWD}; I scalar, RG = 6.7 cm; offset 0"),
    _row(2, 0.0, (6.7,) * 3, _X, (0.001, 0.0, 0.0), _FORWARD, 0.12, (8.16, 0, 0.0),
         f"{_FWD}; I scalar, RG = 6.7 cm; offset 1 mm perpendicular to omega0 (toward the pins)"),
    _row(3, 0.0, (6.7, 6.9, 6.9), _X, _NO, _FORWARD, 0.12, (8.41, 0, 0.0),
         f"{_FWD}; I nonscalar, RG = 6.7, 6.9, 6.9 cm, a_long perpendicular to omega0; offset 0"),
    _row(4, 0.0, (6.7,) * 3, _X, (0.0, 0.001, 0.0), _FORWARD, 0.12, (8.13, 20, 1.4),
         f"{_FWD}; I scalar, RG = 6.7 cm; offset 1 mm parallel to omega0"),
    _row(5, 0.0, (6.7, 6.9, 6.9), (_S75, _C75, 0.0), _NO, _FORWARD, 0.12, (8.60, 7, 0.7),
         f"{_FWD}; I nonscalar, RG = 6.7, 6.9, 6.9 cm, a_long horizontal, 75 deg from omega0; "
         "offset 0"),
    _row(6, -1.8, (6.7,) * 3, _X, _NO, _SIDEWAYS, 0.04, (None, 43, 1.1),
         f"{_SIDE}; I scalar, RG = 6.7 cm; offset 0"),
    _row(7, -1.8, (6.7,) * 3, _X, _NO, _SIDEWAYS, "typical", (None, 66, 6.6),
         f"{_SIDE}; I scalar, RG = 6.7 cm; offset 0"),
    _row(8, -3.0, (6.7,) * 3, _X, _NO, _SIDEWAYS, "typical", (14.72, 124, 5.8),
         f"{_SIDE}; I scalar, RG = 6.7 cm; offset 0"),
    _row(9, -1.0, _RG62, _A_LONG, _NO, _COMBINATION, "typical", (15.60, 51, 3.1),
         f"{_COMBO} (low RG); I scalar, RG = 6.2 cm; offset 0"),
    _row(10, -1.0, _RG62N, _A_LONG, _NO, _COMBINATION, "typical", (15.64, 48, 3.0),
         f"{_COMBO} (low RG); I nonscalar, RG = 6.2, 6.4, 6.4 cm; offset 0"),
    _row(11, -1.0, _RG62, _A_LONG, _OFF_LONG, _COMBINATION, "typical", (15.83, 56, 4.0),
         f"{_COMBO} (low RG); I scalar, RG = 6.2 cm; offset 0.7 mm parallel to a_long"),
    _row(12, -1.0, _RG62N, _A_LONG, _OFF_LONG, _COMBINATION, "typical", (15.84, 53, 3.8),
         f"{_COMBO} (low RG); I nonscalar, RG = 6.2, 6.4, 6.4 cm; "
         "offset 0.7 mm parallel to a_long"),
    _row(13, -1.0, _RG71, _A_LONG, _NO, _COMBINATION, "typical", (16.40, 54, 3.9),
         f"{_COMBO} (high RG); I scalar, RG = 7.1 cm; offset 0"),
    _row(14, -1.0, _RG69N, _A_LONG, _NO, _COMBINATION, "typical", (16.41, 52, 3.6),
         f"{_COMBO} (high RG); I nonscalar, RG = 6.9, 7.1, 7.1 cm; offset 0"),
    _row(15, -1.0, _RG71, _A_LONG, _OFF_LONG, _COMBINATION, "typical", (16.61, 58, 4.8),
         f"{_COMBO} (high RG); I scalar, RG = 7.1 cm; offset 0.7 mm parallel to a_long"),
    _row(16, -1.0, _RG69N, _A_LONG, _OFF_LONG, _COMBINATION, "typical", (16.62, 56, 4.6),
         f"{_COMBO} (high RG); I nonscalar, RG = 6.9, 7.1, 7.1 cm; "
         "offset 0.7 mm parallel to a_long"),
    _row(17, -1.0, _RG69N, _A_LONG, _OFF_LONG, _COMBINATION, 0.04, (None, 37, 1.5),
         f"{_COMBO} (high RG); case 16's ball and delivery"),
    _row(18, -3.0, _RG69N, _A_LONG, _OFF_LONG, _COMBINATION, 0.12, (10.91, 120, 2.7),
         f"{_COMBO} (high RG); case 16's ball and delivery"),
)  # fmt: skip


def _describe(c: PaperCase, variant: Variant) -> str:
    friction = "typical" if c.friction == "typical" else f"constant {c.friction}"
    slide = "to pins" if c.slide_m is None else f"{c.slide_m:.2f} m"
    text = (
        f"Frohlich (2004) Table III case {c.case}: {c.row}; TOA {c.toa_deg:g} deg; friction "
        f"{friction}. Printed: slide {slide}, hook {round(c.hook_m * 100)} cm, pocket angle "
        f"{c.pocket_deg:g} deg."
    )
    if variant == "best_fit":
        text += (
            f" Best-fit variant: oil to {_BEST_FIT_OIL_LENGTH_M} m"
            + (f", released at y = {_BEST_FIT_CASE8_Y0_M} m" if c.case == 8 else "")
            + "."
        )
    return text


def paper_scene(case: int, variant: Variant = "as_written") -> Scene:
    """The scene of Table III case ``case`` (1..18); see the module docstring for variants."""
    if not 1 <= case <= len(TABLE_III):
        raise ValueError(f"case = {case} must be in [1, {len(TABLE_III)}]")
    if variant not in ("as_written", "best_fit"):
        raise ValueError(f"variant = {variant!r} must be 'as_written' or 'best_fit'")
    c = TABLE_III[case - 1]
    best = variant == "best_fit"
    if c.friction == "typical":
        friction: ConstantFriction | TypicalFriction = (
            TypicalFriction(oil_length_m=_BEST_FIT_OIL_LENGTH_M) if best else TypicalFriction()
        )
    else:
        friction = ConstantFriction(mu=c.friction)
    y0 = _BEST_FIT_CASE8_Y0_M if best and case == 8 else 0.5 * _LANE_WIDTH_M
    return Scene(
        name=f"paper-case{case:02d}" + ("-best-fit" if best else ""),
        description=_describe(c, variant),
        ball=Ball(
            mass_kg=_MASS_KG,
            radius_m=_RADIUS_M,
            rg_m=c.rg_m,
            axis_1=c.axis_1,
            com_offset_m=c.com_offset_m,
        ),
        lane=Lane(length_m=_LANE_LENGTH_M, width_m=_LANE_WIDTH_M, friction=friction),
        delivery=Delivery(
            position_m=(0.0, y0),
            speed_mps=_SPEED_MPS,
            takeoff_angle_deg=c.toa_deg,
            omega_radps=c.omega_radps,
        ),
        options=Options(g_mps2=_G_MPS2),
    )


def write_paper_examples(directory: str | Path) -> list[Path]:
    """Write ``case01.json`` ... ``case18.json`` (as-written variant) into ``directory``."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for c in TABLE_III:
        path = out / f"case{c.case:02d}.json"
        path.write_text(dump_scene_json(paper_scene(c.case)), encoding="utf-8")
        paths.append(path)
    return paths
