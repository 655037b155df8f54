"""Drilled holes -> mass properties: the drilled ball's mass, center of mass, inertia tensor,
RG / differential / intermediate differential, static weights and USBC legality.

Units at this boundary: in, oz, lb, deg (field names say which); the tensor math is SI (m, kg,
kg m^2) in the ball-fixed grip frame of :mod:`bowlrec.bowling.ball` (x_g toward the viewer's
right facing the grip with the thumb at 6 o'clock, y_g toward the fingers, z_g out through the
center of grip; h = +1 right-, -1 left-handed, a left-hander's grip is the mirror x_g -> -x_g of
the same numbers).

Model (docs/drilling.md gives the sources and a worked example):

* **Undrilled ball.** Mass M0 (``undrilled_weight_lb``, default the spec sheet's weight), the
  spec sheet's principal moments I_min = M0 RG^2 (pin), I_max = M0 (RG + diff)^2 (PSA),
  I_int = M0 (RG + diff - int_diff)^2 (pin x PSA) about its center of mass, with the pin and PSA
  placed by the layout (:func:`bowlrec.bowling.layout.grip_axes`), and a center-of-mass offset
  from the spec sheet's top weight and the CG mark's position relative to the grip
  (:class:`~bowlrec.bowling.ball.CenterOfMassMark`: the offset L dm / (2 M0) along the CG mark;
  none: the undrilled ball is balanced).
* **Holes.** Each hole takes the ball's material inside a circular cylinder of diameter
  ``diameter_in`` around its axis, which enters the ball's surface at the hole's position, tilted
  by the pitch, down to the plane perpendicular to the axis ``depth_in`` along it from the entry
  point: the sphere's part of that bore, which is open toward the outside (the drill comes in
  from there). Nothing outside the curved surface counts, and a pitched hole also takes the
  ball's material on the uphill side of the entry point's plane. The region's mass, centroid and
  inertia tensor are exact column by column along the axis and Gauss-Legendre across it, to
  1e-10 relative or better (:func:`hole_mass_properties`). Its density is the density of the
  material it cuts, taken uniform (``shell_density_g_cm3``; default the ball's mean density
  M0 / (4/3 pi R^3), about 1.25 g/cm^3 for a 15 lb ball). A hole that reaches a denser core
  removes more mass and changes more than this model says. Each hole is subtracted on its own:
  overlapping openings are rejected (:func:`place_holes`), holes that meet only inside are not
  detected and their common part counts twice.
* **Subtraction.** The undrilled ball's tensor is moved to the ball's geometric center with the
  parallel-axis theorem (I_O = I_C + m (|c|^2 E - c c^T)), the holes' tensors (about that
  center) are subtracted from it, the new center of mass is the mass-weighted difference of
  first moments, and the result is moved back to the new center of mass. Its eigenvalues give
  the drilled RGs; the eigenvector of the smallest is the drilled pin, of the largest the
  drilled PSA.
* **Static weights** come from the drilled center-of-mass offset through the balance-scale
  model of :class:`~bowlrec.bowling.ball.StaticWeights` (d = L dm / (2 M)).

Precedence: measured static weights after drilling (``DrillingSpec.measured_static_weights``,
or a :class:`~bowlrec.bowling.scene.BowlerScene`'s ``balance``) describe the real ball and win
over the computed ones, which rest on the uniform-density assumption above; the computed weights
are still reported beside them.

Pitch: ``forward_pitch_in`` / ``lateral_pitch_in`` are the offsets (in) of the hole's axis from
the ball's center, measured in the plane through the center perpendicular to the radius at the
entry point (a pitch of p tilts the axis by atan(p / R)). Forward (+) leans the hole's bottom
toward the center of grip (drillers' forward pitch; - is reverse pitch; a hole at the center of
grip leans toward the fingers); lateral (+) leans it toward the PAP side (+h x_g: the driller's
right for a right-hander, left for a left-hander).

Span and bridge are edge-to-edge surface distances (the opening's edge taken R asin(a / R) from
the entry point; the elongation of a pitched opening is ignored): the bridge between the two
finger holes, each span from a finger hole to the thumb hole. The middle finger hole is on the
driller's left for a right-hander (-h x_g side), the ring finger hole on the right. The center
of grip is the mean of the two spans' midpoints (between the finger holes' and the thumb hole's
near edges); without a thumb hole it is the bridge center, moved down by
``thumbless_grip_center_down_in`` when the grip center is marked lower (e.g. the palm "+").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from bowlrec.spec import Ball
from bowlrec.spec._base import FiniteFloat, NonNegativeFloat, PositiveFloat, SpecModel, fmt
from bowlrec.spec._base import spec_error as _spec_error
from bowlrec.units import IN_M, LB_KG, OZ_KG

from .ball import (
    BowlerBall,
    CenterOfMassMark,
    Handedness,
    StaticWeights,
    grip_point,
    grip_point_coords,
    handedness_sign,
)
from .layout import PAP, GripAxes, Layout, grip_axes, place_ball
from .legality import LegalityReport, RuleSetName, check_legality

__all__ = [
    "DrilledBall",
    "DrillingSpec",
    "ExtraHole",
    "GripDrilling",
    "HoleMass",
    "HoleSpec",
    "PlacedHole",
    "drill_ball",
    "drill_holes",
    "hole_mass_properties",
    "mean_density_g_cm3",
    "place_hole",
    "place_holes",
]

#: g/cm^3 -> kg/m^3
_G_CM3_KG_M3 = 1000.0
_EPS = 1e-12


class HoleSpec(SpecModel):
    """One drilled hole: a cylinder of diameter x depth, pitched (in)."""

    diameter_in: PositiveFloat = Field(description="Hole diameter (in).")
    depth_in: PositiveFloat = Field(description="Depth along the axis from the surface (in).")
    forward_pitch_in: FiniteFloat = Field(
        default=0.0,
        description="Axis offset at the ball's center toward the center of grip (in); + forward, "
        "- reverse pitch.",
    )
    lateral_pitch_in: FiniteFloat = Field(
        default=0.0,
        description="Axis offset at the ball's center toward the PAP side (in; the driller's "
        "right for a right-hander).",
    )


class ExtraHole(HoleSpec):
    """A hole placed by its position from the center of grip (over / up, in)."""

    name: str = Field(default="extra", min_length=1, description="Label in reports.")
    over_in: FiniteFloat = Field(description="Over from the center of grip, + toward the PAP (in).")
    up_in: FiniteFloat = Field(description="Up from the horizontal midline, + toward fingers (in).")
    purpose: Literal["gripping", "balance"] = Field(
        default="gripping",
        description="'gripping' (a finger or thumb hole, counts toward the gripping-hole limit) or "
        "'balance' (a weight hole; none allowed under the current rules).",
    )


GripStyle = Literal["fingertip", "semi_fingertip", "conventional"]


class GripDrilling(SpecModel):
    """Finger holes placed by the bridge, the thumb hole by the two spans, extra holes by their
    position from the center of grip (module docstring for the conventions)."""

    style: GripStyle = Field(
        default="fingertip",
        description="Grip style as the driller writes it (the spans carry the geometry).",
    )
    middle: HoleSpec = Field(description="Middle-finger hole.")
    ring: HoleSpec = Field(description="Ring-finger hole.")
    thumb: HoleSpec | None = Field(default=None, description="Thumb hole; none: thumbless grip.")
    bridge_in: PositiveFloat = Field(description="Edge-to-edge distance between finger holes (in).")
    middle_span_in: PositiveFloat | None = Field(
        default=None, description="Edge-to-edge, middle-finger hole to thumb hole (in)."
    )
    ring_span_in: PositiveFloat | None = Field(
        default=None, description="Edge-to-edge, ring-finger hole to thumb hole (in)."
    )
    thumbless_grip_center_down_in: NonNegativeFloat = Field(
        default=0.0,
        description="Thumbless: the center of grip this far below the bridge center (in); 0: the "
        "bridge center.",
    )
    extra_holes: list[ExtraHole] = Field(
        default_factory=list, description="Further holes, placed from the center of grip."
    )

    @model_validator(mode="after")
    def _spans_with_thumb(self) -> GripDrilling:
        spans = (self.middle_span_in, self.ring_span_in)
        if self.thumb is not None and None in spans:
            raise _spec_error(
                "middle_span_in and ring_span_in are required with a thumb hole (they place it)"
            )
        if self.thumb is None and spans != (None, None):
            raise _spec_error(
                "middle_span_in / ring_span_in need a thumb hole; a thumbless grip has none"
            )
        if self.thumb is not None and self.thumbless_grip_center_down_in != 0.0:
            raise _spec_error(
                "thumbless_grip_center_down_in applies to a thumbless grip only (thumb is set)"
            )
        return self


class DrillingSpec(SpecModel):
    """A ball, its layout for the bowler's PAP, the grip drilled into it, and what the spec sheet
    says about the undrilled ball's balance: the input of ``bowlrec drill``."""

    ball: BowlerBall = Field(
        description="The spec sheet (RG, diff, int diff of the undrilled ball)."
    )
    layout: Layout = Field(description="Where the pin and PSA sit relative to the PAP.")
    pap: PAP = Field(description="The bowler's positive axis point from the center of grip.")
    grip: GripDrilling = Field(description="The holes.")
    undrilled_cg: CenterOfMassMark | None = Field(
        default=None,
        description="CG mark of the undrilled ball (over / up from the center of grip) with its "
        "top weight (oz) as static_oz; none: the undrilled ball is balanced.",
    )
    undrilled_weight_lb: PositiveFloat | None = Field(
        default=None, description="Undrilled scale weight (lb); none: ball.weight_lb."
    )
    shell_density_g_cm3: PositiveFloat | None = Field(
        default=None,
        description="Density of the drilled material (g/cm^3); none: the ball's mean density.",
    )
    measured_static_weights: StaticWeights | None = Field(
        default=None,
        description="Static weights measured after drilling (oz); they win over the computed ones.",
    )
    rules: RuleSetName = Field(default="current", description="USBC rule set to check.")

    def drill(self) -> DrilledBall:
        """The drilled ball (:func:`drill_ball`)."""
        return drill_ball(
            self.ball,
            self.layout,
            self.pap,
            self.grip,
            undrilled_cg=self.undrilled_cg,
            undrilled_weight_lb=self.undrilled_weight_lb,
            shell_density_g_cm3=self.shell_density_g_cm3,
        )


# --- geometry ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlacedHole:
    """A hole in the grip frame: entry point (unit vector), inward axis (unit), its spec."""

    name: str
    purpose: Literal["gripping", "balance"]
    spec: HoleSpec
    entry: NDArray
    axis: NDArray

    def coords(self, radius_in: float, handedness: Handedness) -> tuple[float, float]:
        """(over_in, up_in) of the entry point from the center of grip."""
        return grip_point_coords(self.entry, radius_in, handedness)


def _unit(v: NDArray, what: str) -> NDArray:
    n = float(np.linalg.norm(v))
    if not n > _EPS:
        raise ValueError(f"{what} is undefined (zero-length vector)")
    return np.asarray(v, dtype=float) / n


def _edge_arc(spec: HoleSpec, radius_in: float) -> float:
    """Surface distance (in) from a hole's entry point to its opening's edge."""
    half = 0.5 * spec.diameter_in
    if not half < radius_in:
        raise ValueError(
            f"diameter_in = {fmt(spec.diameter_in)} must be < the ball's diameter "
            f"{fmt(2 * radius_in)} in"
        )
    return radius_in * math.asin(half / radius_in)


def _prelim_fingers(grip: GripDrilling, r: float, hand: Handedness) -> tuple[NDArray, NDArray]:
    """Middle and ring entry points, symmetric about the vertical midline on the horizontal one
    (the preliminary frame, bridge center at z)."""
    half = 0.5 * grip.bridge_in
    middle = grip_point(-(half + _edge_arc(grip.middle, r)), 0.0, r, hand)
    ring = grip_point(half + _edge_arc(grip.ring, r), 0.0, r, hand)
    return middle, ring


def _thumb_point(grip: GripDrilling, middle: NDArray, ring: NDArray, r: float) -> NDArray:
    """The thumb's entry point below the fingers: the intersection of the two span circles."""
    assert grip.thumb is not None and grip.middle_span_in and grip.ring_span_in
    t_edge = _edge_arc(grip.thumb, r)
    cm = math.cos((grip.middle_span_in + _edge_arc(grip.middle, r) + t_edge) / r)
    cr = math.cos((grip.ring_span_in + _edge_arc(grip.ring, r) + t_edge) / r)
    det = middle[0] * ring[2] - ring[0] * middle[2]
    tx = (cm * ring[2] - cr * middle[2]) / det
    tz = (middle[0] * cr - ring[0] * cm) / det
    rest = 1.0 - tx * tx - tz * tz
    if not rest > 1e-10:
        raise ValueError(
            f"middle_span_in = {fmt(grip.middle_span_in)} and ring_span_in = "
            f"{fmt(grip.ring_span_in)} in cannot both reach one thumb hole (bridge "
            f"{fmt(grip.bridge_in)} in): the span circles do not meet below the fingers"
        )
    return np.array([tx, -math.sqrt(rest), tz])


def _toward(a: NDArray, b: NDArray, arc_in: float, r: float) -> NDArray:
    """The point ``arc_in`` (in) from ``a`` along the great circle toward ``b``."""
    t = _unit(b - float(a @ b) * a, "the direction between two holes")
    return math.cos(arc_in / r) * a + math.sin(arc_in / r) * t


def _grip_center(
    grip: GripDrilling, fingers: tuple[NDArray, NDArray], thumb: NDArray | None, r: float
) -> NDArray:
    """Center of grip in the preliminary frame (the bridge center at +z, h x_g along +x)."""
    if thumb is None:
        return grip_point(0.0, -grip.thumbless_grip_center_down_in, r, "right")
    assert grip.middle_span_in and grip.ring_span_in
    mids = [
        _toward(f, thumb, _edge_arc(spec, r) + 0.5 * span, r)
        for f, spec, span in (
            (fingers[0], grip.middle, grip.middle_span_in),
            (fingers[1], grip.ring, grip.ring_span_in),
        )
    ]
    return _unit(mids[0] + mids[1], "the center of grip")


def _grip_frame(center: NDArray) -> NDArray:
    """Rows x_g, y_g, z_g (preliminary coordinates): z_g at the center of grip, y_g toward the
    bridge center (the preliminary z)."""
    bridge = np.array([0.0, 0.0, 1.0])
    y = bridge - float(bridge @ center) * center
    if not float(np.linalg.norm(y)) > 1e-12:  # center of grip at the bridge center
        y = np.array([0.0, 1.0, 0.0]) - center[1] * center
    y = _unit(y, "the grip's vertical midline")
    return np.stack([np.cross(y, center), y, center])


def _tangent(v: NDArray, entry: NDArray, fwd: NDArray | None = None) -> NDArray | None:
    """The unit part of ``v`` perpendicular to ``entry`` (and to ``fwd``); None if it vanishes."""
    t = v - float(v @ entry) * entry
    if fwd is not None:
        t = t - float(t @ fwd) * fwd
    n = float(np.linalg.norm(t))
    return t / n if n > 1e-9 else None


def _hole_axis(spec: HoleSpec, entry: NDArray, r: float, h: int) -> NDArray:
    """Inward unit axis of a hole entering at ``entry`` (grip frame), pitched: forward toward
    the center of grip (toward the fingers for a hole at the center of grip), lateral toward
    +h x_g (toward the fingers for a hole on the horizontal midline, where +h x_g is forward)."""
    x, y, z = np.eye(3)
    fwd = _tangent(z, entry)
    if fwd is None:
        fwd = _tangent(y, entry)
    side = _tangent(h * x, entry, fwd)
    if side is None:
        side = _tangent(y, entry, fwd)
    assert fwd is not None and side is not None
    return _unit(-r * entry + spec.forward_pitch_in * fwd + spec.lateral_pitch_in * side, "axis")


def place_holes(grip: GripDrilling, radius_in: float, handedness: Handedness) -> list[PlacedHole]:
    """Every hole's entry point and inward axis in the grip frame (the frame whose z_g is the
    center of grip this drilling defines)."""
    r, h = radius_in, handedness_sign(handedness)
    fingers = _prelim_fingers(grip, r, handedness)
    thumb = None if grip.thumb is None else _thumb_point(grip, *fingers, r)
    frame = _grip_frame(_grip_center(grip, fingers, thumb, r))
    named: list[tuple[str, HoleSpec, NDArray]] = [
        ("middle", grip.middle, frame @ fingers[0]),
        ("ring", grip.ring, frame @ fingers[1]),
    ]
    if grip.thumb is not None and thumb is not None:
        named.append(("thumb", grip.thumb, frame @ thumb))
    holes = [PlacedHole(n, "gripping", s, e, _hole_axis(s, e, r, h)) for n, s, e in named]
    holes += [place_hole(x, r, handedness) for x in grip.extra_holes]
    _check_fit(holes, r)
    return holes


def place_hole(hole: ExtraHole, radius_in: float, handedness: Handedness) -> PlacedHole:
    """An extra hole's entry point and inward axis in the grip frame."""
    e = grip_point(hole.over_in, hole.up_in, radius_in, handedness)
    axis = _hole_axis(hole, e, radius_in, handedness_sign(handedness))
    return PlacedHole(hole.name, hole.purpose, hole, e, axis)


def _check_fit(holes: list[PlacedHole], r: float) -> None:
    """Each hole's bottom inside the ball; no two openings overlap."""
    for hole in holes:
        a, d = 0.5 * hole.spec.diameter_in, hole.spec.depth_in
        bottom = r * hole.entry + d * hole.axis
        perp = bottom - float(bottom @ hole.axis) * hole.axis
        reach = math.sqrt(float(bottom @ bottom) + a * a + 2 * a * float(np.linalg.norm(perp)))
        if reach > r * (1 + 1e-12):
            raise ValueError(
                f"hole {hole.name!r}: depth_in = {fmt(d)} with diameter_in = "
                f"{fmt(hole.spec.diameter_in)} reaches {reach:.6g} in from the center, past the "
                f"ball's radius {fmt(r)} in"
            )
    for i, p in enumerate(holes):
        for q in holes[i + 1 :]:
            gap = r * math.acos(max(-1.0, min(1.0, float(p.entry @ q.entry))))
            gap -= _edge_arc(p.spec, r) + _edge_arc(q.spec, r)
            if gap < -1e-9:
                raise ValueError(
                    f"holes {p.name!r} and {q.name!r} overlap (edge-to-edge {gap:.4g} in)"
                )


# --- mass properties ---------------------------------------------------------------------------
def mean_density_g_cm3(weight_lb: float, diameter_in: float) -> float:
    """Mean density (g/cm^3) of a ball of this weight (lb) and diameter (in)."""
    volume_m3 = 4.0 / 3.0 * math.pi * (0.5 * diameter_in * IN_M) ** 3
    return weight_lb * LB_KG / volume_m3 / _G_CM3_KG_M3


@dataclass(frozen=True)
class HoleMass:
    """Mass properties of the material one hole removes (SI, grip frame; the inertia tensor about
    the ball's geometric center)."""

    name: str
    purpose: Literal["gripping", "balance"]
    diameter_in: float
    mass_kg: float
    centroid_m: NDArray
    inertia_center_kg_m2: NDArray

    @property
    def mass_oz(self) -> float:
        """Removed mass (oz)."""
        return self.mass_kg / OZ_KG


def _parallel(mass: float, c: NDArray) -> NDArray:
    """m (|c|^2 E - c c^T): the parallel-axis term for a point mass at ``c``."""
    return mass * (float(c @ c) * np.eye(3) - np.outer(c, c))


#: Quadrature levels (Gauss-Legendre nodes across the hole; twice as many around it) and the
#: relative agreement of two successive levels at which the finer one is returned.
_LEVELS = (8, 16, 32, 64)
_LEVEL_TOL = 1e-10


@cache
def _gauss(n: int) -> tuple[NDArray, NDArray]:
    """Gauss-Legendre nodes and weights on [-1, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return x, w


def _perpendicular(u: NDArray) -> NDArray:
    """A unit vector perpendicular to the unit ``u``."""
    k = int(np.argmin(np.abs(u)))
    v = np.eye(3)[k] - u[k] * u
    return v / float(np.linalg.norm(v))


def _angle_rule(a: float, b: float, rho: float, n: int) -> tuple[NDArray, NDArray, NDArray]:
    """Angles phi (0 toward the axis's foot q), their weights and the radius r_max(phi) of the
    part of the cross-section whose columns hold material: the rim r = a, cut by the circle
    |q + w| = rho where the bore's bottom plane leaves the sphere on the entry side (rho = inf:
    it does not). A trapezoid rule (n nodes) around a smooth boundary, Gauss-Legendre (n per
    arc) between the corners where the two circles cross."""
    trapezoid = (np.arange(n) + 0.5) * (2.0 * math.pi / n), np.full(n, 2.0 * math.pi / n)
    if a + b <= rho:  # every column holds material
        return *trapezoid, np.full(n, a)
    if b <= _EPS * rho:  # concentric circles, rho < a
        return *trapezoid, np.full(n, rho)
    cos_k = (rho * rho - a * a - b * b) / (2.0 * a * b)
    if cos_k <= -1.0:  # the circle rho lies inside the rim
        phi, weight = trapezoid
    else:  # corners at +-phi_k: the circle rho bounds |phi| < phi_k, the rim the rest
        x, w = _gauss(n)
        k = math.acos(cos_k)
        phi = np.concatenate([k * x, math.pi + (math.pi - k) * x])
        weight = np.concatenate([k * w, (math.pi - k) * w])
    c = b * np.cos(phi)
    exit_r = np.sqrt(c * c + rho * rho - b * b) - c  # where the ray leaves the circle rho
    return phi, weight, np.minimum(exit_r, a)


def _bore_moments(a: float, b: float, s_d: float, radius: float, n: int) -> NDArray:
    """The bore region's volume integrals of 1, x, y, s, xx, xy, xs, yy, ys, ss in the hole's
    coordinates (x toward the axis's foot q, s along the inward axis from q; m), with n
    Gauss-Legendre nodes across the radius r = |w| and 2n around (:func:`hole_mass_properties`).
    """
    rho = math.sqrt(max(radius * radius - s_d * s_d, 0.0)) if s_d < 0.0 else math.inf
    phi, w_phi, r_max = _angle_rule(a, b, rho, 2 * n)
    gx, gw = _gauss(n)
    half = 0.5 * r_max[:, None]
    r = half * (gx + 1.0)
    weight = (w_phi[:, None] * half * gw) * r  # dA = r dr dphi
    x = b + r * np.cos(phi)[:, None]  # q + w in the cross-section
    y = r * np.sin(phi)[:, None]
    h = np.sqrt(np.maximum(radius * radius - x * x - y * y, 0.0))  # the sphere at s = -h, +h
    top = np.minimum(s_d, h)
    inside = top > -h
    s0 = np.where(inside, top + h, 0.0)  # the column's integrals of 1, s, s^2
    s1 = np.where(inside, 0.5 * (top * top - h * h), 0.0)
    s2 = np.where(inside, (top**3 + h**3) / 3.0, 0.0)
    xs0, ys0 = x * s0, y * s0
    terms = np.stack([s0, xs0, ys0, s1, x * xs0, y * xs0, x * s1, y * ys0, y * s1, s2])
    return np.asarray(terms.reshape(10, -1) @ weight.ravel())


def hole_mass_properties(hole: PlacedHole, radius_m: float, density_kg_m3: float) -> HoleMass:
    """A hole's mass (kg), centroid (m) and inertia tensor about the ball's center (kg m^2): of
    the material the bore takes, the sphere's part of the half-infinite cylinder of radius a
    around the hole's axis that ends in the plane at depth d below the entry point. The drill
    comes in from outside, so the cylinder has no top face: nothing outside the sphere counts,
    and a pitched hole also takes the material on the uphill side of the entry point's plane.

    Coordinates: s along the inward axis u from the axis's foot q (its point nearest the
    center), w across it (|w| <= a). The column at w holds material for -h(w) <= s <= s_d, with
    h(w) = sqrt(R^2 - |q + w|^2) and s_d the bottom's s; its integrals of 1, s, s^2 are exact.
    The cross-section integrals, analytic in w, are Gauss-Legendre in |w| times a trapezoid rule
    in the angle, on levels of 8, 16, 32, 64 radial nodes until two agree to 1e-10 (relative);
    the finer is returned (docs/drilling.md, "Holes", for the accuracy)."""
    a, d = 0.5 * hole.spec.diameter_in * IN_M, hole.spec.depth_in * IN_M
    u = hole.axis
    entry = radius_m * hole.entry
    s_entry = float(entry @ u)
    q = entry - s_entry * u
    b = float(np.linalg.norm(q))
    e1 = q / b if b > _EPS * radius_m else _perpendicular(u)
    scale = np.array([1.0, a, a, a, a * a, a * a, a * a, a * a, a * a, a * a])
    moments = _bore_moments(a, b, s_entry + d, radius_m, _LEVELS[0])
    for n in _LEVELS[1:]:
        coarse, moments = moments, _bore_moments(a, b, s_entry + d, radius_m, n)
        if np.all(np.abs(moments - coarse) <= _LEVEL_TOL * moments[0] * scale):
            break
    # the region is symmetric about the plane of u and q (y -> -y): the y-odd integrals vanish
    v, fx, _, fs, sxx, _, sxs, syy, _, sss = moments
    if b > _EPS * radius_m:
        basis = np.stack([e1, np.cross(u, e1), u])  # rows: the hole's axes in the grip frame
        first = density_kg_m3 * (basis.T @ np.array([fx, 0.0, fs]))
        local = np.array([[sxx, 0.0, sxs], [0.0, syy, 0.0], [sxs, 0.0, sss]])
        second = density_kg_m3 * (basis.T @ local @ basis)
    else:  # and about the axis, when it passes through the center
        first = density_kg_m3 * fs * u
        across = 0.5 * (sxx + syy)
        second = density_kg_m3 * (across * np.eye(3) + (sss - across) * np.outer(u, u))
    inertia = float(np.trace(second)) * np.eye(3) - second
    mass = density_kg_m3 * float(v)
    return HoleMass(hole.name, hole.purpose, hole.spec.diameter_in, mass, first / mass, inertia)


@dataclass(frozen=True)
class DrilledBall:
    """The drilled ball (SI, grip frame unless a name says otherwise).

    ``inertia_kg_m2`` is about the drilled center of mass; ``principal_axes`` are its unit
    eigenvectors as rows (low, intermediate, high RG: the drilled pin, the third axis, the
    drilled PSA), each signed toward the undrilled pin / pin x PSA / PSA. ``computed_weights``
    are the static weights the model gives; :meth:`static_weights` lets measured ones win.
    """

    ball: BowlerBall
    handedness: Handedness
    undrilled_mass_kg: float
    shell_density_g_cm3: float
    holes: tuple[HoleMass, ...]
    placed: tuple[PlacedHole, ...]
    mass_kg: float
    com_offset_m: NDArray
    inertia_kg_m2: NDArray
    principal_moments_kg_m2: tuple[float, float, float]
    principal_axes: NDArray
    undrilled_axes: NDArray
    undrilled_weights: StaticWeights
    computed_weights: StaticWeights

    @property
    def weight_lb(self) -> float:
        """Drilled weight (lb)."""
        return self.mass_kg / LB_KG

    @property
    def removed_oz(self) -> float:
        """Mass removed by all holes (oz)."""
        return (self.undrilled_mass_kg - self.mass_kg) / OZ_KG

    @property
    def rg_in(self) -> tuple[float, float, float]:
        """(RG_min, RG_int, RG_max) of the drilled ball (in)."""
        lo, mid, hi = (math.sqrt(i / self.mass_kg) / IN_M for i in self.principal_moments_kg_m2)
        return lo, mid, hi

    @property
    def differential_in(self) -> float:
        """RG_max - RG_min (in)."""
        return self.rg_in[2] - self.rg_in[0]

    @property
    def intermediate_differential_in(self) -> float:
        """RG_max - RG_int (in)."""
        return self.rg_in[2] - self.rg_in[1]

    @property
    def gripping_holes(self) -> int:
        """Number of gripping holes (finger, thumb and extra gripping holes)."""
        return sum(1 for hole in self.holes if hole.purpose == "gripping")

    @property
    def balance_hole_diameters_in(self) -> tuple[float, ...]:
        """Diameters of the balance holes (in)."""
        return tuple(hole.diameter_in for hole in self.holes if hole.purpose == "balance")

    def axis_moved_in(self, which: Literal["pin", "psa"]) -> float:
        """Surface distance (in) from the undrilled pin (PSA) to the drilled low- (high-) RG
        axis. For a symmetric ball the drilled PSA is set by the holes alone (the undrilled
        "PSA" is the layout's nominal point), so it can move far."""
        i, j = (0, 0) if which == "pin" else (2, 1)
        cos = float(self.principal_axes[i] @ self.undrilled_axes[j])
        return self.ball.radius_in * math.acos(max(-1.0, min(1.0, cos)))

    def axis_position_in(self, which: Literal["pin", "psa"]) -> tuple[float, float]:
        """(over_in, up_in) of the drilled pin (PSA) from the center of grip."""
        v = self.principal_axes[0 if which == "pin" else 2]
        return grip_point_coords(v, self.ball.radius_in, self.handedness)

    def static_weights(self, measured: StaticWeights | None = None) -> StaticWeights:
        """The static weights to use: ``measured`` ones (after drilling, on a scale) when given,
        since they describe the real ball; otherwise the computed ones."""
        return measured if measured is not None else self.computed_weights

    def drilled_spec(self) -> BowlerBall:
        """The drilled ball as a spec sheet (weight, RG, diff, int diff after drilling)."""
        idiff = self.intermediate_differential_in
        return self.ball.model_copy(
            update={
                "weight_lb": self.weight_lb,
                "rg_in": self.rg_in[0],
                "differential_in": self.differential_in,
                "intermediate_differential_in": idiff if idiff > 0.0 else 0.0,
                "core_type": "asymmetric" if idiff > 0.0 else "symmetric",
            }
        )

    def legality(
        self, rules: RuleSetName = "current", measured: StaticWeights | None = None
    ) -> LegalityReport:
        """The drilled ball under ``rules``: weight, diameter, drilled RG and differential,
        static weights (``measured`` win over computed), gripping and balance holes."""
        return check_legality(
            self.drilled_spec(),
            rules,
            static_weights=self.static_weights(measured),
            gripping_holes=self.gripping_holes,
            balance_hole_diameters_in=self.balance_hole_diameters_in,
        )

    def to_ball(
        self,
        pap: PAP,
        omega_dir_lane: NDArray | tuple[float, float, float],
        *,
        roll_about_pap_deg: float = 0.0,
        measured: StaticWeights | None = None,
        travel_dir_lane: NDArray | tuple[float, float, float] = (1.0, 0.0, 0.0),
    ) -> Ball:
        """The physical drilled :class:`~bowlrec.spec.Ball` at release (SI, lane frame), placed
        as :func:`bowlrec.bowling.layout.resolve_ball` places an undrilled one: axis_1 the
        drilled pin, axis_2 the drilled PSA, the center-of-mass offset from ``measured`` static
        weights when given, else the computed one."""
        offset = (
            self.com_offset_m
            if measured is None
            else measured.com_offset_grip_m(self.mass_kg, pap.handedness)
        )
        lo, mid, hi = (x * IN_M for x in self.rg_in)
        axes = GripAxes(
            pap=pap.point(self.ball.radius_in),
            pin=self.principal_axes[0],
            psa=self.principal_axes[2],
        )
        return place_ball(
            self.mass_kg,
            self.ball.radius_m,
            (lo, hi, mid),
            axes,
            offset,
            pap,
            omega_dir_lane,
            roll_about_pap_deg=roll_about_pap_deg,
            travel_dir_lane=travel_dir_lane,
        )


def _undrilled_tensor(ball: BowlerBall, mass_kg: float, axes: NDArray) -> NDArray:
    """Spec-sheet inertia tensor (kg m^2, about the undrilled center of mass, grip frame) with
    rows of ``axes`` = pin, pin x PSA, PSA."""
    moments = np.array([ball.rg_min_in, ball.rg_int_in, ball.rg_max_in]) * IN_M
    return np.asarray(axes.T @ np.diag(mass_kg * moments**2) @ axes)


def _principal(inertia: NDArray, reference: NDArray) -> tuple[NDArray, NDArray]:
    """Eigenvalues (ascending) and unit eigenvectors as rows, each signed toward the matching
    row of ``reference``."""
    values, vectors = np.linalg.eigh(0.5 * (inertia + inertia.T))
    rows = vectors.T.copy()
    for k in range(3):
        if float(rows[k] @ reference[k]) < 0.0:
            rows[k] = -rows[k]
    return values, rows


def drill_ball(
    ball: BowlerBall,
    layout: Layout,
    pap: PAP,
    grip: GripDrilling,
    *,
    undrilled_cg: CenterOfMassMark | None = None,
    undrilled_weight_lb: float | None = None,
    shell_density_g_cm3: float | None = None,
) -> DrilledBall:
    """Drill ``grip`` into ``ball`` laid out as ``layout`` for ``pap`` (module docstring for the
    model). ``undrilled_cg``: the undrilled ball's CG mark (over / up from the center of grip,
    in) with its top weight (oz) as ``static_oz``; ``undrilled_weight_lb``: the undrilled scale
    weight (lb, default ``ball.weight_lb``); ``shell_density_g_cm3``: density of the drilled
    material (default the ball's mean density)."""
    placed = place_holes(grip, ball.radius_in, pap.handedness)
    return drill_holes(
        ball,
        layout,
        pap,
        placed,
        undrilled_cg=undrilled_cg,
        undrilled_weight_lb=undrilled_weight_lb,
        shell_density_g_cm3=shell_density_g_cm3,
    )


def drill_holes(
    ball: BowlerBall,
    layout: Layout,
    pap: PAP,
    placed: list[PlacedHole],
    *,
    undrilled_cg: CenterOfMassMark | None = None,
    undrilled_weight_lb: float | None = None,
    shell_density_g_cm3: float | None = None,
) -> DrilledBall:
    """:func:`drill_ball` with the holes already placed in the grip frame (:func:`place_holes`,
    :func:`place_hole`)."""
    hand = pap.handedness
    m0 = (undrilled_weight_lb or ball.weight_lb) * LB_KG
    density = shell_density_g_cm3 or mean_density_g_cm3(m0 / LB_KG, ball.diameter_in)
    ax = grip_axes(ball, layout, pap)
    undrilled_axes = np.stack([ax.pin, np.cross(ax.pin, ax.psa), ax.psa])
    c0 = np.zeros(3)
    if undrilled_cg is not None:
        c0 = undrilled_cg.com_offset_grip_m(m0, ball.radius_in, hand)
    inertia_o = _undrilled_tensor(ball, m0, undrilled_axes) + _parallel(m0, c0)
    holes = tuple(hole_mass_properties(p, ball.radius_m, density * _G_CM3_KG_M3) for p in placed)
    mass = m0 - sum(hm.mass_kg for hm in holes)
    if not mass > 0.0:
        raise ValueError("the holes remove the whole ball (check diameters and depths)")
    first = m0 * c0 - sum((hm.mass_kg * hm.centroid_m for hm in holes), np.zeros(3))
    com = first / mass
    inertia_o = inertia_o - sum((hm.inertia_center_kg_m2 for hm in holes), np.zeros((3, 3)))
    inertia = inertia_o - _parallel(mass, com)
    values, axes = _principal(inertia, undrilled_axes)
    return DrilledBall(
        ball=ball,
        handedness=hand,
        undrilled_mass_kg=m0,
        shell_density_g_cm3=density,
        holes=holes,
        placed=tuple(placed),
        mass_kg=mass,
        com_offset_m=com,
        inertia_kg_m2=inertia,
        principal_moments_kg_m2=(float(values[0]), float(values[1]), float(values[2])),
        principal_axes=axes,
        undrilled_axes=undrilled_axes,
        undrilled_weights=StaticWeights.from_com_offset_grip(c0, m0, hand),
        computed_weights=StaticWeights.from_com_offset_grip(com, mass, hand),
    )
