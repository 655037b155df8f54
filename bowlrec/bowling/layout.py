"""Drilling layouts and the bowler's PAP, resolved to principal axes in the lane frame.

Geometry is on the ball's surface (sphere of radius R = diameter_in / 2); a surface distance d
(in) is the central angle theta = d / R. Points are unit vectors in the ball-fixed grip frame of
:mod:`bowlrec.bowling.ball` (x_g: the viewer's right facing the grip with the thumb at 6
o'clock, y_g: toward the fingers, z_g: out through the center of grip); h = +1 for a right-,
-1 for a left-hander. A left-hander's layout is the mirror (x_g -> -x_g) of the same numbers.

Definitions (domain notes Sec. 3):

* **PAP** (positive axis point): where the initial rotation axis meets the surface:
  ``over_in`` along the horizontal midline toward the bowler's hand side of the layout sheet
  (the driller's right for a right-hander, holding the ball fingers up and thumb at 6 o'clock),
  then ``up_in`` perpendicular to it toward the fingers. In the lane frame at release the PAP
  is ``h * omega_hat``. At release the grip faces the bowler with the thumb above the fingers,
  turned 180 deg from the driller's view, so the layout sheet's right is the bowler's left: a
  right-hander's forward roll has omega along +y (the bowler's left) and side roll adds
  omega_x < 0 (hook to the left), so the PAP sits on the ball's left, toward the back. With
  positive tilt (omega_z > 0) it is the raised end of the axis; the track is the small circle
  90 deg + tilt from it. A left-hander's PAP is the mirror image of the right-hander's, which
  is ``-omega_hat`` of the mirrored spin (omega is an axial vector).
* **VAL** (vertical axis line): the great circle through the PAP perpendicular to the horizontal
  midline (it runs through the PAP toward the finger pole y_g). ``v`` is its tangent at the
  PAP toward the fingers; ``g = h (p x v)`` is the tangent at the PAP toward the grip.
* **Dual Angle** ``drilling_angle x pin_to_pap x val_angle``: the pin is pin_to_pap along the
  great circle leaving the PAP at val_angle from v toward g::

      pin = cos(t_pin) p + sin(t_pin) (cos(VAL) v + sin(VAL) g)

  the drilling angle is the angle at the pin from the pin->PAP line to the pin->PSA line
  (pin->CG for a symmetric ball), clockwise seen from outside for a right-hander
  (counterclockwise for a left-hander): rotating the pin->CG line counterclockwise by the
  drilling angle gives the pin->PAP line [DA-TS]. The PSA is 90 deg (R pi / 2) from the pin.
* **VLS** ``pin_to_pap x psa_to_pap x pin_buffer``: pin_buffer is the distance from the pin to
  the VAL; ``pin_above_pap`` says on which side of the horizontal great circle through the PAP
  the pin is (True: val_angle <= 90 deg).
* **2LS** (Storm's two-hand / thumbless layout system) ``pin_to_pap x psa_to_pap x
  pin_to_grip_center`` (in): the pin is where the circle of radius pin_to_pap about the PAP
  meets the circle of radius pin_to_grip_center about the center of grip (z_g), on the finger
  side of the great circle through the PAP and the center of grip (the side of the finger pole
  y_g; ``pin_toward_fingers=False`` takes the other intersection); the PSA is psa_to_pap from
  the PAP, 90 deg from the pin, on the standard Dual Angle side of the pin->PAP line (as for
  VLS). Order of the numbers and the finger-side rule: Storm's 2LS drilling instructions as
  implemented and tested by [LA] (docs/drilling.md lists the sources and where they disagree).
  For a thumbless grip the center of grip is the midpoint of the bridge [LA]. Unlike Dual Angle
  and VLS the third number depends on the PAP, so every 2LS conversion takes the PAP.
* Conversions (spherical law of cosines / sines, the PSA 90 deg from the pin)::

      psa_to_pap = R acos(sin(t_pin) cos(DA))      DA  = acos(cos(t_psa) / sin(t_pin))
      pin_buffer = R asin(sin(t_pin) sin(VAL))     VAL = asin(sin(t_buf) / sin(t_pin))

  Dual Angle drilling angles lie in [0, 180] deg: VLS cannot tell the PSA's side of the
  pin->PAP line, and this is the side of the standard Dual Angle convention. 2LS <-> Dual
  Angle, with p the PAP, (v, g) its VAL frame, A = v . z_g, B = g . z_g, beta = atan2(B, A)
  (the direction of the center of grip seen from the PAP, measured like the VAL angle)::

      cos(t_grip) = cos(t_pin) (p . z_g) + sin(t_pin) (A cos(VAL) + B sin(VAL))
      VAL = beta -+ acos((cos(t_grip) - cos(t_pin) (p . z_g)) / (sin(t_pin) hypot(A, B)))

  (minus: pin toward the fingers) and the drilling angle as from VLS.
* For a **symmetric** ball there is no PSA; the "PSA" is the point 90 deg from the pin on the
  pin->CG great circle (which high-RG axis is chosen does not change I; it only fixes the
  drilling-angle reference).

Resolution (:func:`resolve_ball`): the grip-frame PAP is rotated onto ``h omega_hat``; the
remaining rotation about the PAP is ``roll_about_pap_deg``: 0 turns the center of grip as far
as it goes toward the bowler (in the half-plane through the rotation axis that contains the
backward release direction, -v_hat; straight up when the axis is horizontal along v), positive
values rotate it by h * roll about the PAP direction (right-hand rule), so equal numbers for a
left-hander give the exact mirror (y -> -y) of a right-hander.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator, model_validator

from bowlrec.spec import Ball
from bowlrec.spec._base import FiniteFloat, NonNegativeFloat, PositiveFloat, SpecModel, Vec3, fmt
from bowlrec.spec._base import spec_error as _spec_error

from .ball import (
    BowlerBall,
    CenterOfMassMark,
    Handedness,
    StaticWeights,
    grip_point,
    grip_point_coords,
    handedness_sign,
)

__all__ = [
    "PAP",
    "DualAngle",
    "ExampleLibrary",
    "ExplicitAxes",
    "ExplicitPositions",
    "GripAxes",
    "Layout",
    "LayoutSystem",
    "TwoLS",
    "VLS",
    "convert_layout",
    "dual_angle_from_axes",
    "dual_angle_to_two_ls",
    "dual_angle_to_vls",
    "explicit_positions",
    "grip_axes",
    "grip_to_lane_rotation",
    "load_example_library",
    "pap_lane_direction",
    "place_ball",
    "resolve_ball",
    "two_ls_to_dual_angle",
    "two_ls_to_vls",
    "vls_to_dual_angle",
    "vls_to_two_ls",
]

_EPS = 1e-12
_LIBRARY_PATH = Path(__file__).parent / "data" / "balls.json"


class PAP(SpecModel):
    """The bowler's positive axis point, measured from the center of grip (in)."""

    over_in: PositiveFloat = Field(
        le=13.5,
        description="Horizontal distance along the midline toward the hand side (in), in (0, "
        "13.5]: an arc on the ball, at most half a standard ball's circumference.",
    )
    up_in: FiniteFloat = Field(
        default=0.0,
        ge=-6.75,
        le=6.75,
        description="Vertical distance, + up (in), in [-6.75, 6.75]: an arc, at most a quarter "
        "of a standard ball's circumference.",
    )
    handedness: Handedness = Field(default="right", description="'right' or 'left'.")

    def point(self, radius_in: float) -> NDArray:
        """Unit vector of the PAP in the grip frame."""
        return grip_point(self.over_in, self.up_in, radius_in, self.handedness)


class DualAngle(SpecModel):
    """Mo Pinel's Dual Angle layout: drilling angle (deg) x pin-to-PAP (in) x VAL angle (deg)."""

    system: Literal["dual_angle"] = "dual_angle"
    drilling_angle_deg: float = Field(
        ge=0, le=180, description="At the pin, pin->PAP to pin->PSA (CG) line (deg), [0, 180]."
    )
    pin_to_pap_in: PositiveFloat = Field(description="Pin to PAP surface distance (in).")
    val_angle_deg: float = Field(
        ge=0, le=180, description="At the PAP, VAL (toward fingers) to PAP->pin line (deg)."
    )


class VLS(SpecModel):
    """Storm's Vector Layout System: pin-to-PAP x PSA-to-PAP x pin buffer (in)."""

    system: Literal["vls"] = "vls"
    pin_to_pap_in: PositiveFloat = Field(description="Pin to PAP surface distance (in).")
    psa_to_pap_in: NonNegativeFloat = Field(description="PSA (MB) to PAP surface distance (in).")
    pin_buffer_in: NonNegativeFloat = Field(description="Pin to VAL surface distance (in).")
    pin_above_pap: bool = Field(
        default=True,
        description="Pin above (toward the fingers from) the horizontal line through the PAP.",
    )


class TwoLS(SpecModel):
    """Storm's 2LS: pin-to-PAP x PSA (MB)-to-PAP x pin-to-center-of-grip (in); the pin on the
    finger side of the great circle through the PAP and the center of grip unless
    ``pin_toward_fingers`` is False (module docstring)."""

    system: Literal["2ls"] = "2ls"
    pin_to_pap_in: PositiveFloat = Field(description="Pin to PAP surface distance (in).")
    psa_to_pap_in: NonNegativeFloat = Field(description="PSA (MB) to PAP surface distance (in).")
    pin_to_grip_center_in: NonNegativeFloat = Field(
        description="Pin to center of grip surface distance (in); thumbless: to the bridge center."
    )
    pin_toward_fingers: bool = Field(
        default=True,
        description="Pin on the finger side of the great circle through the PAP and the center "
        "of grip (Storm's placement); False: the other intersection.",
    )


class ExplicitPositions(SpecModel):
    """Pin and PSA (CG for a symmetric ball) as surface positions from the center of grip."""

    system: Literal["explicit"] = "explicit"
    pin_over_in: FiniteFloat = Field(description="Pin: over from the center of grip (in).")
    pin_up_in: FiniteFloat = Field(description="Pin: up from the horizontal midline (in).")
    psa_over_in: FiniteFloat = Field(description="PSA / CG: over from the center of grip (in).")
    psa_up_in: FiniteFloat = Field(description="PSA / CG: up from the horizontal midline (in).")


class ExplicitAxes(SpecModel):
    """The principal axes as grip-frame vectors (normalized; high axis made perpendicular)."""

    system: Literal["axes"] = "axes"
    low_rg_axis: Vec3 = Field(description="Pin direction (low-RG axis) in the grip frame.")
    high_rg_axis: Vec3 = Field(description="PSA direction (high-RG axis) in the grip frame.")

    @field_validator("low_rg_axis", "high_rg_axis")
    @classmethod
    def _nonzero(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        if not math.hypot(*v) > _EPS:
            raise _spec_error(f"axis {v} must be a nonzero vector (only its direction is used)")
        return v


Layout = Annotated[
    DualAngle | VLS | TwoLS | ExplicitPositions | ExplicitAxes, Field(discriminator="system")
]
#: the three layout systems drillers write as three numbers
LayoutSystem = Literal["dual_angle", "vls", "2ls"]


# --- Dual Angle <-> VLS ------------------------------------------------------------------------
def _clip(x: float) -> float:
    return max(-1.0, min(1.0, x))


def dual_angle_to_vls(da: DualAngle, radius_in: float) -> VLS:
    """VLS numbers of a Dual Angle layout on a ball of radius ``radius_in`` (in)."""
    t_pin = da.pin_to_pap_in / radius_in
    a, val = math.radians(da.drilling_angle_deg), math.radians(da.val_angle_deg)
    return VLS(
        pin_to_pap_in=da.pin_to_pap_in,
        psa_to_pap_in=radius_in * math.acos(_clip(math.sin(t_pin) * math.cos(a))),
        pin_buffer_in=radius_in * math.asin(_clip(math.sin(t_pin) * math.sin(val))),
        pin_above_pap=da.val_angle_deg <= 90.0,
    )


def vls_to_dual_angle(vls: VLS, radius_in: float) -> DualAngle:
    """Dual Angle numbers of a VLS layout; raises ValueError when no such layout exists."""
    t_pin, t_psa = vls.pin_to_pap_in / radius_in, vls.psa_to_pap_in / radius_in
    t_buf = vls.pin_buffer_in / radius_in
    s = math.sin(t_pin)
    cos_da, sin_val = math.cos(t_psa) / s, math.sin(t_buf) / s
    if not (abs(cos_da) <= 1.0 and 0.0 <= sin_val <= 1.0 and t_pin < math.pi):
        raise ValueError(
            f"VLS {fmt(vls.pin_to_pap_in)} x {fmt(vls.psa_to_pap_in)} x "
            f"{fmt(vls.pin_buffer_in)} in is impossible on a ball of radius {fmt(radius_in)} in: "
            f"need |cos(psa_to_pap / R)| <= sin(pin_to_pap / R) (got {abs(math.cos(t_psa)):.6g}"
            f" vs {s:.6g}) and sin(pin_buffer / R) <= sin(pin_to_pap / R) (got "
            f"{math.sin(t_buf):.6g})"
        )
    val = math.degrees(math.asin(sin_val))
    return DualAngle(
        drilling_angle_deg=math.degrees(math.acos(cos_da)),
        pin_to_pap_in=vls.pin_to_pap_in,
        val_angle_deg=val if vls.pin_above_pap else 180.0 - val,
    )


# --- grip-frame geometry -----------------------------------------------------------------------
def _unit(v: NDArray, what: str) -> NDArray:
    n = float(np.linalg.norm(v))
    if not n > _EPS:
        raise ValueError(f"{what} is undefined (zero-length vector)")
    return np.asarray(v, dtype=float) / n


def _rotate(v: NDArray, axis: NDArray, angle: float) -> NDArray:
    """Rodrigues rotation of ``v`` by ``angle`` (rad) about the unit ``axis`` (right-hand)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def _val_frame(pap: NDArray, h: int) -> tuple[NDArray, NDArray]:
    """(v, g): tangents at the PAP toward the fingers (along the VAL) and toward the grip."""
    f = np.array([0.0, 1.0, 0.0])
    v = _unit(f - float(f @ pap) * pap, "the VAL (PAP at the finger pole)")
    return v, h * np.cross(pap, v)


@dataclass(frozen=True)
class GripAxes:
    """PAP, pin (low-RG axis) and PSA (high-RG axis) as unit vectors in the grip frame."""

    pap: NDArray
    pin: NDArray
    psa: NDArray

    @property
    def intermediate(self) -> NDArray:
        """Third principal axis, pin x PSA."""
        return np.cross(self.pin, self.psa)


def _axes_from_angles(t_pin: float, val: float, drill: float, pap: NDArray, h: int) -> NDArray:
    """(pin, psa) stacked as rows: the pin t_pin (rad) from the PAP at VAL angle ``val`` (rad,
    any real), the PSA at drilling angle ``drill`` (rad) from the pin->PAP line."""
    v, g = _val_frame(pap, h)
    pin = math.cos(t_pin) * pap + math.sin(t_pin) * (math.cos(val) * v + math.sin(val) * g)
    to_pap = _unit(pap - float(pap @ pin) * pin, "the pin->PAP direction (pin at the PAP)")
    psa = _rotate(to_pap, pin, -h * drill)
    return np.stack([pin, psa])


def _dual_angle_axes(da: DualAngle, pap: NDArray, radius_in: float, h: int) -> NDArray:
    """(pin, psa) of a Dual Angle layout, stacked as rows."""
    return _axes_from_angles(
        da.pin_to_pap_in / radius_in,
        math.radians(da.val_angle_deg),
        math.radians(da.drilling_angle_deg),
        pap,
        h,
    )


def _orthogonal_pair(pin: NDArray, psa: NDArray) -> NDArray:
    pin = _unit(pin, "the pin axis")
    psa = _unit(psa - float(psa @ pin) * pin, "the PSA axis (parallel to the pin axis)")
    return np.stack([pin, psa])


# --- 2LS <-> Dual Angle <-> VLS ----------------------------------------------------------------
def _drilling_angle_from_psa(pin_to_pap_in: float, psa_to_pap_in: float, radius_in: float) -> float:
    """Drilling angle (rad, [0, pi]) of a pin and PSA at these distances from the PAP (the PSA
    90 deg from the pin, on the standard Dual Angle side); ValueError when impossible."""
    s = math.sin(pin_to_pap_in / radius_in)
    cos_da = math.cos(psa_to_pap_in / radius_in) / s if s > _EPS else math.inf
    if not abs(cos_da) <= 1.0:
        raise ValueError(
            f"pin_to_pap = {fmt(pin_to_pap_in)} in and psa_to_pap = {fmt(psa_to_pap_in)} in are "
            f"impossible on a ball of radius {fmt(radius_in)} in with the PSA 90 deg from the "
            f"pin: need |cos(psa_to_pap / R)| <= sin(pin_to_pap / R) (got "
            f"{abs(math.cos(psa_to_pap_in / radius_in)):.6g} vs {s:.6g})"
        )
    return math.acos(cos_da)


def _grip_center_bearing(pap: NDArray, h: int) -> tuple[float, float]:
    """(beta, rho): the direction of the center of grip seen from the PAP, measured like the VAL
    angle (rad), and the length of its tangent component (A, B) = (v . z_g, g . z_g)."""
    v, g = _val_frame(pap, h)
    a, b = float(v[2]), float(g[2])
    return math.atan2(b, a), math.hypot(a, b)


def _two_ls_val(tls: TwoLS, pap: NDArray, radius_in: float, h: int) -> float:
    """VAL angle (rad, in (-pi, pi]) of a 2LS pin; ValueError when the two circles miss."""
    t_pin, t_grip = tls.pin_to_pap_in / radius_in, tls.pin_to_grip_center_in / radius_in
    beta, rho = _grip_center_bearing(pap, h)
    denom = math.sin(t_pin) * rho
    if not denom > _EPS:
        raise ValueError(
            f"2LS is undefined for pin_to_pap_in = {fmt(tls.pin_to_pap_in)} in with this PAP: the "
            "pin must be off the PAP and its antipode and the PAP off the center of grip and its "
            "antipode, else pin_to_grip_center_in does not locate the pin"
        )
    x = (math.cos(t_grip) - math.cos(t_pin) * float(pap[2])) / denom
    if not abs(x) <= 1.0 + 1e-12:
        raise ValueError(
            f"2LS {fmt(tls.pin_to_pap_in)} x {fmt(tls.psa_to_pap_in)} x "
            f"{fmt(tls.pin_to_grip_center_in)} in is impossible for this PAP: no point is "
            f"pin_to_pap_in = {fmt(tls.pin_to_pap_in)} in from the PAP and "
            f"pin_to_grip_center_in = {fmt(tls.pin_to_grip_center_in)} in from the center of grip "
            f"on a ball of radius {fmt(radius_in)} in (the circles miss: {x:.6g} is outside "
            "[-1, 1])"
        )
    omega = math.acos(_clip(x))
    val = beta - omega if tls.pin_toward_fingers else beta + omega
    return math.atan2(math.sin(val), math.cos(val))


def _pap_vector(pap: PAP, radius_in: float) -> tuple[NDArray, int]:
    return pap.point(radius_in), handedness_sign(pap.handedness)


def two_ls_to_dual_angle(tls: TwoLS, pap: PAP, radius_in: float) -> DualAngle:
    """Dual Angle numbers of a 2LS layout for the bowler's ``pap`` on a ball of radius
    ``radius_in`` (in); ValueError when no such layout exists or its VAL angle falls outside
    [0, 180] deg (the pin on the far side of the VAL, which 2LS can describe and Dual Angle
    cannot)."""
    p, h = _pap_vector(pap, radius_in)
    val = _two_ls_val(tls, p, radius_in, h)
    drill = _drilling_angle_from_psa(tls.pin_to_pap_in, tls.psa_to_pap_in, radius_in)
    if val < -1e-12:
        raise ValueError(
            f"2LS {fmt(tls.pin_to_pap_in)} x {fmt(tls.psa_to_pap_in)} x "
            f"{fmt(tls.pin_to_grip_center_in)} in puts the pin at VAL angle "
            f"{math.degrees(val):.6g} deg (on the far side of the VAL from the grip); Dual Angle "
            "VAL angles are in [0, 180] deg"
        )
    return DualAngle(
        drilling_angle_deg=math.degrees(drill),
        pin_to_pap_in=tls.pin_to_pap_in,
        val_angle_deg=min(180.0, math.degrees(max(val, 0.0))),
    )


def dual_angle_to_two_ls(da: DualAngle, pap: PAP, radius_in: float) -> TwoLS:
    """2LS numbers of a Dual Angle layout for the bowler's ``pap`` (radius ``radius_in``, in)."""
    p, h = _pap_vector(pap, radius_in)
    pin = _dual_angle_axes(da, p, radius_in, h)[0]
    beta, _ = _grip_center_bearing(p, h)
    val = math.radians(da.val_angle_deg)
    psa = radius_in * math.acos(
        _clip(
            math.sin(da.pin_to_pap_in / radius_in) * math.cos(math.radians(da.drilling_angle_deg))
        )
    )
    return TwoLS(
        pin_to_pap_in=da.pin_to_pap_in,
        psa_to_pap_in=psa,
        pin_to_grip_center_in=radius_in * math.acos(_clip(float(pin[2]))),
        pin_toward_fingers=math.sin(val - beta) <= 0.0,
    )


def two_ls_to_vls(tls: TwoLS, pap: PAP, radius_in: float) -> VLS:
    """VLS numbers of a 2LS layout (through its Dual Angle form)."""
    return dual_angle_to_vls(two_ls_to_dual_angle(tls, pap, radius_in), radius_in)


def vls_to_two_ls(vls: VLS, pap: PAP, radius_in: float) -> TwoLS:
    """2LS numbers of a VLS layout (through its Dual Angle form)."""
    return dual_angle_to_two_ls(vls_to_dual_angle(vls, radius_in), pap, radius_in)


def convert_layout(
    layout: DualAngle | VLS | TwoLS, system: LayoutSystem, pap: PAP, radius_in: float
) -> DualAngle | VLS | TwoLS:
    """``layout`` written in ``system`` ('dual_angle', 'vls' or '2ls') for the bowler's ``pap``
    on a ball of radius ``radius_in`` (in); ValueError when the target cannot describe it."""
    if layout.system == system:
        return layout
    da = layout
    if isinstance(layout, VLS):
        da = vls_to_dual_angle(layout, radius_in)
    elif isinstance(layout, TwoLS):
        da = two_ls_to_dual_angle(layout, pap, radius_in)
    assert isinstance(da, DualAngle)
    if system == "dual_angle":
        return da
    if system == "vls":
        return dual_angle_to_vls(da, radius_in)
    if system == "2ls":
        return dual_angle_to_two_ls(da, pap, radius_in)
    raise ValueError(f"system = {system!r} must be one of 'dual_angle', 'vls', '2ls'")


def grip_axes(ball: BowlerBall, layout: Layout, pap: PAP) -> GripAxes:
    """PAP, pin and PSA directions in the grip frame for ``layout`` drilled for ``pap``."""
    r, h = ball.radius_in, handedness_sign(pap.handedness)
    p = pap.point(r)
    if isinstance(layout, VLS):
        layout = vls_to_dual_angle(layout, r)
    if isinstance(layout, TwoLS):
        val = _two_ls_val(layout, p, r, h)
        drill = _drilling_angle_from_psa(layout.pin_to_pap_in, layout.psa_to_pap_in, r)
        pair = _axes_from_angles(layout.pin_to_pap_in / r, val, drill, p, h)
    elif isinstance(layout, DualAngle):
        pair = _dual_angle_axes(layout, p, r, h)
    elif isinstance(layout, ExplicitPositions):
        pin = grip_point(layout.pin_over_in, layout.pin_up_in, r, pap.handedness)
        psa = grip_point(layout.psa_over_in, layout.psa_up_in, r, pap.handedness)
        pair = _orthogonal_pair(pin, psa)
    else:
        pair = _orthogonal_pair(np.array(layout.low_rg_axis), np.array(layout.high_rg_axis))
    return GripAxes(pap=p, pin=pair[0], psa=pair[1])


def dual_angle_from_axes(axes: GripAxes, radius_in: float, handedness: Handedness) -> DualAngle:
    """The Dual Angle numbers of grip-frame axes (the inverse of the Dual Angle construction);
    raises ValueError when either angle falls outside [0, 180] deg."""
    h = handedness_sign(handedness)
    p, pin, psa = axes.pap, axes.pin, axes.psa
    v, g = _val_frame(p, h)
    t_pin = math.acos(_clip(float(p @ pin)))
    to_pin = pin - float(p @ pin) * p
    val = math.atan2(float(to_pin @ g), float(to_pin @ v))
    to_pap = _unit(p - float(p @ pin) * pin, "the pin->PAP direction")
    da = math.atan2(-h * float(pin @ np.cross(to_pap, psa)), float(to_pap @ psa))
    if val < -_EPS or da < -_EPS:
        raise ValueError(
            f"no Dual Angle form: VAL angle {math.degrees(val):.6g} deg and drilling angle "
            f"{math.degrees(da):.6g} deg must both be in [0, 180] deg (pin on the grip side of "
            "the VAL, PSA on the standard side of the pin->PAP line)"
        )
    return DualAngle(
        drilling_angle_deg=math.degrees(max(da, 0.0)),
        pin_to_pap_in=t_pin * radius_in,
        val_angle_deg=math.degrees(max(val, 0.0)),
    )


def explicit_positions(
    axes: GripAxes, radius_in: float, handedness: Handedness
) -> ExplicitPositions:
    """Pin and PSA surface positions (over / up from the center of grip) of grip-frame axes."""
    pin_over, pin_up = grip_point_coords(axes.pin, radius_in, handedness)
    psa_over, psa_up = grip_point_coords(axes.psa, radius_in, handedness)
    return ExplicitPositions(
        pin_over_in=pin_over, pin_up_in=pin_up, psa_over_in=psa_over, psa_up_in=psa_up
    )


# --- lane frame --------------------------------------------------------------------------------
#: the release direction of travel when none is given: straight down the lane (+x)
_DOWN_LANE = (1.0, 0.0, 0.0)


def pap_lane_direction(omega_dir_lane: NDArray, handedness: Handedness) -> NDArray:
    """The PAP's lane-frame direction at release: h * omega_hat (h = +1 right-handed)."""
    w = _unit(np.asarray(omega_dir_lane, dtype=float), "omega_dir_lane")
    return handedness_sign(handedness) * w


def _toward_bowler(p: NDArray, travel_dir_lane: NDArray) -> NDArray:
    """Unit vector perpendicular to the PAP ``p`` closest to the backward release direction
    (straight up when the PAP lies along the travel)."""
    back = -_unit(np.asarray(travel_dir_lane, dtype=float), "travel_dir_lane")
    rest = back - float(back @ p) * p
    if float(np.linalg.norm(rest)) > 1e-9:
        return _unit(rest, "the backward direction about the PAP")
    z = np.array([0.0, 0.0, 1.0])
    return _unit(z - float(z @ p) * p, "'up' about a vertical rotation axis")


def grip_to_lane_rotation(
    pap_grip: NDArray,
    pap_lane: NDArray,
    roll_about_pap_deg: float,
    handedness: Handedness,
    travel_dir_lane: NDArray | tuple[float, float, float] = _DOWN_LANE,
) -> NDArray:
    """Rotation matrix (grip -> lane) taking ``pap_grip`` to ``pap_lane``; for roll 0 the
    center of grip faces the bowler as squarely as it can (toward -``travel_dir_lane``, the
    backward release direction), otherwise it is turned by h * roll about the PAP."""
    h = handedness_sign(handedness)
    a = _unit(pap_grip, "the PAP")
    c = np.array([0.0, 0.0, 1.0])
    b = _unit(c - float(c @ a) * a, "the center of grip about the PAP (PAP at the grip)")
    p = _unit(pap_lane, "the PAP in the lane frame")
    back = _toward_bowler(p, np.asarray(travel_dir_lane, dtype=float))
    d = _rotate(back, p, h * math.radians(roll_about_pap_deg))
    lane = np.column_stack([p, d, np.cross(p, d)])
    grip = np.column_stack([a, b, np.cross(a, b)])
    return lane @ grip.T


def _balance_offset_grip(
    ball: BowlerBall, balance: StaticWeights | CenterOfMassMark | None, hand: Handedness
) -> NDArray:
    if balance is None:
        return np.zeros(3)
    if isinstance(balance, StaticWeights):
        return balance.com_offset_grip_m(ball.mass_kg, hand)
    return balance.com_offset_grip_m(ball.mass_kg, ball.radius_in, hand)


def _vec(v: NDArray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def resolve_ball(
    ball: BowlerBall,
    layout: Layout,
    pap: PAP,
    omega_dir_lane: NDArray | tuple[float, float, float],
    *,
    roll_about_pap_deg: float = 0.0,
    balance: StaticWeights | CenterOfMassMark | None = None,
    travel_dir_lane: NDArray | tuple[float, float, float] = _DOWN_LANE,
) -> Ball:
    """The physical :class:`~bowlrec.spec.Ball` at release (SI, lane frame).

    ``omega_dir_lane``: direction of the initial angular velocity (lane frame; its length is
    ignored); the PAP is placed at h * omega_hat. ``travel_dir_lane``: direction of the release
    velocity (length ignored); with ``roll_about_pap_deg`` 0 the grip faces back along it.
    ``axis_1`` is the pin (low RG), ``axis_2`` the PSA (high RG), axis 3 = axis_1 x axis_2, so
    ``rg_m`` = (RG_min, RG_max, RG_int). ``com_offset_m`` comes from ``balance`` (static
    weights after drilling, or a center-of-mass mark); none means a perfectly balanced drilled ball.
    """
    axes = grip_axes(ball, layout, pap)
    return place_ball(
        ball.mass_kg,
        ball.radius_m,
        ball.rg_m,
        axes,
        _balance_offset_grip(ball, balance, pap.handedness),
        pap,
        omega_dir_lane,
        roll_about_pap_deg=roll_about_pap_deg,
        travel_dir_lane=travel_dir_lane,
    )


def place_ball(
    mass_kg: float,
    radius_m: float,
    rg_m: tuple[float, float, float],
    axes: GripAxes,
    offset_grip_m: NDArray,
    pap: PAP,
    omega_dir_lane: NDArray | tuple[float, float, float],
    *,
    roll_about_pap_deg: float = 0.0,
    travel_dir_lane: NDArray | tuple[float, float, float] = _DOWN_LANE,
) -> Ball:
    """A ball with grip-frame ``axes`` (PAP, pin, PSA) and center-of-mass offset
    ``offset_grip_m`` (m) placed in the lane frame at release, as :func:`resolve_ball`
    describes; ``rg_m`` = (RG about the pin, about the PSA, about pin x PSA) (m)."""
    p_lane = pap_lane_direction(np.asarray(omega_dir_lane, dtype=float), pap.handedness)
    rot = grip_to_lane_rotation(
        axes.pap, p_lane, roll_about_pap_deg, pap.handedness, travel_dir_lane
    )
    return Ball(
        mass_kg=mass_kg,
        radius_m=radius_m,
        rg_m=rg_m,
        axis_1=_vec(rot @ axes.pin),
        axis_2=_vec(rot @ axes.psa),
        com_offset_m=_vec(rot @ offset_grip_m),
    )


# --- curated example library -------------------------------------------------------------------
from .catalog import Source, citation  # noqa: E402  (the catalog's source model)

#: assumptions a catalog entry may declare for values its sources do not state
AssumedField = Literal["weight_lb", "surface", "core_type", "coverstock"]


class _Entry(SpecModel):
    id: str = Field(min_length=1, description="Library key.")
    illustrative: bool = Field(description="True: illustrative values, not from a source.")
    note: str = Field(default="", description="Free text: conflicts, conversions, caveats.")


class _Sourced(_Entry):
    source: str = Field(min_length=1, description="Where the numbers come from (citation).")


class BallEntry(_Entry):
    """A ball spec in the curated catalog, with its release year and public sources."""

    year: int | None = Field(
        default=None,
        ge=1900,
        le=2100,
        description="Release year; null when no source read gives it (year_note says why).",
    )
    year_note: str = Field(
        min_length=1, description="What the year rests on, or what bounds the sources give."
    )
    sources: list[Source] = Field(
        min_length=1, description="Public sources, the one the numbers are taken from first."
    )
    assumed: list[AssumedField] = Field(
        default_factory=list,
        description="Fields set by assumption because no source read states them (see note).",
    )
    ball: BowlerBall

    @model_validator(mode="after")
    def _consistent(self) -> BallEntry:
        """Sourced entries quote their numbers; declared assumptions are explained."""
        if not self.illustrative and not self.sources[0].quote:
            raise _spec_error(f"{self.id}: the first source needs a quote of the numbers")
        if self.assumed and "assum" not in self.note:
            raise _spec_error(f"{self.id}: assumed fields {self.assumed} need a note saying so")
        return self

    @property
    def source(self) -> str:
        """All sources as one text (``; ``-separated citation lines)."""
        return "; ".join(citation(s) for s in self.sources)

    @property
    def second_hand(self) -> str | None:
        """The kind of the source the numbers come from ('review' or 'database') when no
        source is the maker's own sheet read here (a manufacturer source with a quote); None
        otherwise."""
        read_from_maker = any(s.kind == "manufacturer" and s.quote for s in self.sources)
        kind = self.sources[0].kind
        return kind if kind in ("review", "database") and not read_from_maker else None


class LayoutEntry(_Sourced):
    """A layout in the example library."""

    layout: Layout


class PAPEntry(_Sourced):
    """A bowler's PAP in the example library."""

    pap: PAP


class StaticWeightsEntry(_Sourced):
    """Static weights after drilling in the example library."""

    static_weights: StaticWeights


class ExampleLibrary(SpecModel):
    """The curated catalog of ``bowlrec/bowling/data/balls.json``, keyed by id."""

    format: Literal["bowlrec-bowling-examples"]
    version: Literal[2]
    description: str = ""
    balls: list[BallEntry]
    layouts: list[LayoutEntry]
    paps: list[PAPEntry]
    static_weights: list[StaticWeightsEntry]

    @model_validator(mode="after")
    def _unique_ids(self) -> ExampleLibrary:
        for kind in ("balls", "layouts", "paps", "static_weights"):
            ids = [e.id for e in getattr(self, kind)]
            dup = sorted({i for i in ids if ids.count(i) > 1})
            if dup:
                raise _spec_error(f"{kind}: duplicate ids {dup}")
        return self

    def ball(self, entry_id: str) -> BowlerBall:
        """The ball spec with id ``entry_id``."""
        return _find(self.balls, entry_id, "balls").ball

    def layout(self, entry_id: str) -> DualAngle | VLS | TwoLS | ExplicitPositions | ExplicitAxes:
        """The layout with id ``entry_id``."""
        return _find(self.layouts, entry_id, "layouts").layout

    def pap(self, entry_id: str) -> PAP:
        """The PAP with id ``entry_id``."""
        return _find(self.paps, entry_id, "paps").pap


def _find(entries: list[Any], entry_id: str, kind: str) -> Any:
    for e in entries:
        if e.id == entry_id:
            return e
    raise KeyError(f"no {kind} entry {entry_id!r}; known: {[e.id for e in entries]}")


def load_example_library(path: str | Path | None = None) -> ExampleLibrary:
    """Load and validate the curated example library (default: the packaged balls.json)."""
    text = Path(path or _LIBRARY_PATH).read_text(encoding="utf-8")
    return ExampleLibrary.model_validate(json.loads(text))
