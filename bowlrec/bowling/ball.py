"""A bowling ball as a manufacturer's spec sheet gives it, its markings, and its static weights.

Units at this boundary: lb, in, oz (exact constants in :mod:`bowlrec.units`); everything
derived is SI (kg, m, kg m^2).

Principal moments from the spec sheet (Frohlich 2004, Table I; domain notes Sec. 1.2)::

    I_min = m RG^2                      (about the pin / low-RG axis)
    I_max = m (RG + diff)^2             (about the PSA / high-RG axis)
    I_int = m (RG + diff - int_diff)^2  (the third principal axis)

with RG the published (low) RG, diff = RG_max - RG_min and int_diff = RG_max - RG_int (the
difference between the two high-RG axes; 0 for a symmetric core). The triangle inequality of
principal moments (I_max <= I_min + I_int) holds whenever RG + diff <= sqrt(2) RG, i.e. diff <=
0.414 RG ~ 1 in; a legal ball (diff <= 0.060 in, RG >= 2.46 in) satisfies it by a factor of ~17,
so it only bites for nonsensical specs, which are rejected here with that explanation.

The grip frame (ball-fixed, used by layouts and static weights). Hold the ball facing you, the
thumb hole at 6 o'clock and the finger holes above it (the driller's view of Frohlich's Table I):

* ``z_g`` (``c``): from the ball's center out through the center of grip;
* ``y_g`` (``f``): tangent at the center of grip toward the finger holes ("up", along the VAL);
* ``x_g`` (``r``): tangent at the center of grip toward the viewer's right; ``x_g x y_g = z_g``.

A surface point is written as bowlers measure the PAP: ``over_in`` along the horizontal midline
(the great circle through the center of grip perpendicular to the vertical midline), positive
toward the bowler's PAP side (the viewer's right for a right-hander, left for a left-hander),
then ``up_in`` perpendicular to that midline toward the fingers (negative = down). Both are arc
lengths on the ball's surface, so with R the ball's radius, o = over/R, u = up/R and h = +1 (right)
or -1 (left) the unit vector is ``(h sin(o) cos(u), sin(u), cos(o) cos(u))``. A left-hander's
numbers are therefore the mirror image (x_g -> -x_g) of the same numbers for a right-hander.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator, model_validator

from bowlrec.spec._base import (
    FiniteFloat,
    NonNegativeFloat,
    PositiveFloat,
    SpecModel,
    fmt,
    spec_error,
)
from bowlrec.units import IN_M, LB_KG, OZ_KG

from .surface import Coverstock

__all__ = [
    "FROHLICH_LEVER_ARM_M",
    "MARKING_MEANINGS",
    "BowlerBall",
    "CenterOfMassMark",
    "CoreType",
    "Coverstock",
    "Handedness",
    "Marking",
    "StaticWeights",
    "grip_point",
    "grip_point_coords",
    "handedness_sign",
    "spec_from_moments",
]

Handedness = Literal["right", "left"]
CoreType = Literal["symmetric", "asymmetric"]

#: lever arm of the ABC/WIBC static-weight balance (Frohlich 2004, Sec. III A and Fig. 3) (m)
FROHLICH_LEVER_ARM_M = 0.162
#: the physical limits (bowlrec.spec.limits) in bowlers' units
MAX_WEIGHT_LB = 220.0
MAX_DIAMETER_IN = 78.0
#: sqrt(2) - 1: diff / RG above which the principal moments break the triangle inequality
_TRIANGLE_DIFF_RATIO = math.sqrt(2.0) - 1.0


class Marking(StrEnum):
    """Marks on a ball's surface (Frohlich 2004 Table I; domain notes Sec. 1.3)."""

    PIN = "pin"
    CG = "cg"
    PSA = "psa"


#: what each marking locates, in physicists' language
MARKING_MEANINGS: dict[Marking, str] = {
    Marking.PIN: (
        "pin: where the low-RG (weight-block symmetry) principal axis meets the surface "
        "(USBC since 2012: within 1 in of the pin's center)"
    ),
    Marking.CG: (
        "CG / label: where the center-of-mass offset axis of the undrilled ball meets the "
        "surface (the heavy side before drilling)"
    ),
    Marking.PSA: (
        "mass bias / PSA marker (asymmetric cores only): where the high-RG principal axis "
        "meets the surface (USBC since 2012: within 1.5 in of the marker)"
    ),
}


def handedness_sign(handedness: Handedness) -> int:
    """+1 for a right-hander, -1 for a left-hander."""
    if handedness == "right":
        return 1
    if handedness == "left":
        return -1
    raise ValueError(f"handedness = {handedness!r} must be 'right' or 'left'")


def grip_point(over_in: float, up_in: float, radius_in: float, handedness: Handedness) -> NDArray:
    """Unit vector (grip frame) of the surface point ``over_in`` / ``up_in`` from the center of
    grip (arc lengths, in; see the module docstring)."""
    h = handedness_sign(handedness)
    o, u = over_in / radius_in, up_in / radius_in
    return np.array([h * math.sin(o) * math.cos(u), math.sin(u), math.cos(o) * math.cos(u)])


def grip_point_coords(
    point: NDArray, radius_in: float, handedness: Handedness
) -> tuple[float, float]:
    """Inverse of :func:`grip_point`: (over_in, up_in) of a unit vector in the grip frame."""
    h = handedness_sign(handedness)
    p = np.asarray(point, dtype=float) / float(np.linalg.norm(point))
    up = math.asin(max(-1.0, min(1.0, float(p[1]))))
    over = math.atan2(h * float(p[0]), float(p[2]))
    return over * radius_in, up * radius_in


class BowlerBall(SpecModel):
    """A ball as its spec sheet describes it (undrilled, per weight; lb, in).

    Published RG and differential are CAD figures for the undrilled ball (domain notes Sec. 1.2);
    bowlrec uses them for the drilled ball, and ``weight_lb`` as the drilled ball's mass.
    Legality is not enforced here (see :mod:`bowlrec.bowling.legality`); only physical
    consistency is.
    """

    name: str = Field(min_length=1, description="Ball name as the manufacturer prints it.")
    brand: str = Field(default="", description="Manufacturer.")
    weight_lb: PositiveFloat = Field(
        le=MAX_WEIGHT_LB,
        description=f"Weight (lb), in (0, {MAX_WEIGHT_LB:g}]; also the mass used (lb -> kg).",
    )
    diameter_in: PositiveFloat = Field(
        default=8.595,
        le=MAX_DIAMETER_IN,
        description=f"Diameter (in), in (0, {MAX_DIAMETER_IN:g}]; USBC allows 8.500-8.595 in.",
    )
    rg_in: PositiveFloat = Field(
        description="Published RG: the low radius of gyration, about the pin axis (in)."
    )
    differential_in: NonNegativeFloat = Field(
        description="Total differential RG_max - RG_min (in)."
    )
    intermediate_differential_in: NonNegativeFloat = Field(
        default=0.0,
        description=(
            "Intermediate (mass-bias) differential RG_max - RG_int between the two high-RG "
            "axes (in); 0 for a symmetric core, > 0 for an asymmetric one."
        ),
    )
    core_type: CoreType = Field(
        default="symmetric",
        description="'symmetric' (two equal high RGs) or 'asymmetric' (three distinct RGs).",
    )
    coverstock: Coverstock = Field(
        description=(
            "Coverstock class: polyester, urethane, reactive_solid, reactive_pearl, "
            "reactive_hybrid or particle."
        )
    )
    surface: int | Literal["polished"] = Field(
        default="polished",
        description="Surface: a grit number (e.g. 2000 for 2000 Abralon) or 'polished'.",
    )
    finish: str = Field(
        default="", description="Factory finish as printed, e.g. '500/1000 + polish'."
    )

    @field_validator("surface")
    @classmethod
    def _grit_positive(cls, v: int | str) -> int | str:
        """A grit number must be positive."""
        if isinstance(v, int) and v <= 0:
            raise spec_error(f"surface = {v} must be a grit number > 0 or 'polished'")
        return v

    @model_validator(mode="after")
    def _consistent(self) -> BowlerBall:
        """Core type vs intermediate differential; RGs inside the ball; triangle inequality."""
        idiff, diff = self.intermediate_differential_in, self.differential_in
        if idiff > diff:
            raise spec_error(
                f"intermediate_differential_in = {fmt(idiff)} must be <= differential_in = "
                f"{fmt(diff)} (RG_int = RG + diff - int_diff cannot be below the low RG)"
            )
        if self.core_type == "symmetric" and idiff != 0.0:
            raise spec_error(
                f"intermediate_differential_in = {fmt(idiff)} must be 0 for core_type = "
                "'symmetric' (two equal high RGs); use core_type = 'asymmetric'"
            )
        if self.core_type == "asymmetric" and not idiff > 0.0:
            raise spec_error(
                "intermediate_differential_in = 0.0 must be > 0 for core_type = 'asymmetric': "
                "with equal high RGs the core is dynamically symmetric and has no PSA; use "
                "core_type = 'symmetric'"
            )
        if not diff <= _TRIANGLE_DIFF_RATIO * self.rg_in:
            raise spec_error(
                f"differential_in = {fmt(diff)} must be <= (sqrt(2) - 1) * rg_in = "
                f"{fmt(_TRIANGLE_DIFF_RATIO * self.rg_in)} (else I_max > I_min + I_int, which "
                "no rigid body has)"
            )
        rg_max = self.rg_in + diff
        if not rg_max < self.radius_in:
            raise spec_error(
                f"rg_in + differential_in = {fmt(rg_max)} must be < the radius "
                f"diameter_in / 2 = {fmt(self.radius_in)} (a radius of gyration cannot exceed "
                "the radius)"
            )
        return self

    # --- derived quantities -------------------------------------------------------------------
    @property
    def mass_kg(self) -> float:
        """Mass (kg)."""
        return self.weight_lb * LB_KG

    @property
    def radius_in(self) -> float:
        """Radius (in)."""
        return 0.5 * self.diameter_in

    @property
    def radius_m(self) -> float:
        """Radius (m)."""
        return self.radius_in * IN_M

    @property
    def rg_min_in(self) -> float:
        """Low RG, about the pin axis (in)."""
        return self.rg_in

    @property
    def rg_max_in(self) -> float:
        """High RG, about the PSA (in)."""
        return self.rg_in + self.differential_in

    @property
    def rg_int_in(self) -> float:
        """Intermediate RG, about the third principal axis (in)."""
        return self.rg_in + self.differential_in - self.intermediate_differential_in

    @property
    def rg_m(self) -> tuple[float, float, float]:
        """(RG_min, RG_max, RG_int) in m: the order bowlrec's ``Ball.rg_m`` uses for
        (axis_1 = pin, axis_2 = PSA, axis_3 = pin x PSA)."""
        return (self.rg_min_in * IN_M, self.rg_max_in * IN_M, self.rg_int_in * IN_M)

    @property
    def principal_moments_kg_m2(self) -> tuple[float, float, float]:
        """(I_min, I_int, I_max) in kg m^2."""
        m = self.mass_kg
        return (
            m * (self.rg_min_in * IN_M) ** 2,
            m * (self.rg_int_in * IN_M) ** 2,
            m * (self.rg_max_in * IN_M) ** 2,
        )

    @property
    def diff_ratio(self) -> float:
        """Intermediate differential / total differential (0 when the total is 0)."""
        d = self.differential_in
        return self.intermediate_differential_in / d if d > 0 else 0.0

    @property
    def markings(self) -> tuple[Marking, ...]:
        """The marks this ball carries: pin and CG, plus the PSA marker if asymmetric."""
        if self.core_type == "asymmetric":
            return (Marking.PIN, Marking.CG, Marking.PSA)
        return (Marking.PIN, Marking.CG)

    def spec_sheet(self) -> str:
        """The ball as a spec sheet prints it (one field per line)."""
        surface = "polished" if self.surface == "polished" else f"{self.surface} grit"
        lines = [
            f"{self.brand} {self.name}".strip(),
            f"  Weight          {self.weight_lb:g} lb",
            f"  Diameter        {self.diameter_in:.3f} in",
            f"  RG              {self.rg_in:.3f} in",
            f"  Differential    {self.differential_in:.3f} in",
        ]
        if self.core_type == "asymmetric":
            lines.append(f"  Int. diff (MB)  {self.intermediate_differential_in:.3f} in")
        lines += [
            f"  Core            {self.core_type}",
            f"  Coverstock      {self.coverstock.replace('_', ' ')}",
            f"  Surface         {surface}" + (f" ({self.finish})" if self.finish else ""),
        ]
        return "\n".join(lines)


def spec_from_moments(
    mass_kg: float, i_min: float, i_int: float, i_max: float
) -> tuple[float, float, float]:
    """(rg_in, differential_in, intermediate_differential_in) from principal moments (kg m^2):
    the inverse of :attr:`BowlerBall.principal_moments_kg_m2`."""
    if not 0 < i_min <= i_int <= i_max:
        raise ValueError(
            f"principal moments must satisfy 0 < i_min <= i_int <= i_max, got "
            f"({fmt(i_min)}, {fmt(i_int)}, {fmt(i_max)}) kg m^2"
        )
    rg_min, rg_int, rg_max = (math.sqrt(i / mass_kg) / IN_M for i in (i_min, i_int, i_max))
    return rg_min, rg_max - rg_min, rg_max - rg_int


class StaticWeights(SpecModel):
    """Static weights after drilling as a balance scale reads them (oz), and their
    center-of-mass offset.

    Balance-scale model (Frohlich 2004, Sec. III A and Fig. 3). The ball is clamped with its
    geometric center at horizontal distance L from the fulcrum; let d be the component of the
    center-of-mass offset (center -> center of mass) along the lever arm, away from the fulcrum.
    Balancing takes a counter-torque M g (L + d). Rotated 180 deg about the vertical the ball
    needs M g (L - d); the scale reading is the extra mass dm that, acting at the same arm L,
    makes up the difference: dm g L = 2 M g d, so::

        d = L dm / (2 M)        (L = 0.162 m, M = ball mass)

    Each reading is one such dm along one grip-frame axis (module docstring), positive toward:

    * ``top_oz``: the center of grip (top weight; negative = bottom weight), ``+z_g``;
    * ``finger_oz``: the finger holes (finger weight; negative = thumb weight), ``+y_g``;
    * ``side_oz``: the bowler's PAP side (positive side weight; negative = negative side
      weight), ``+h x_g``: the viewer's right for a right-hander, left for a left-hander.

    Side-weight sign: pro-shop usage puts positive side weight on the PAP side of the grip
    midline. Frohlich's Table I calls positive side weight "left" ("toward the left when facing
    the holes with the thumb at 6 o'clock"); for a right-hander the PAP side is the ball's left
    at release, where his P2 puts the extra hook, while a driller facing the holes with the
    thumb at 6 o'clock sees it on the right. bowlrec follows the pro-shop (PAP-side) convention,
    which agrees with P2. Example: 3 oz on a 16 lb ball is an offset of 0.949 mm, Frohlich's
    "r_Delta must be 1 mm or less" for the 3 oz limit.
    """

    top_oz: FiniteFloat = Field(default=0.0, description="Top (+) / bottom (-) weight (oz).")
    side_oz: FiniteFloat = Field(
        default=0.0, description="Positive (+, PAP side) / negative (-) side weight (oz)."
    )
    finger_oz: FiniteFloat = Field(default=0.0, description="Finger (+) / thumb (-) weight (oz).")
    lever_arm_m: PositiveFloat = Field(
        default=FROHLICH_LEVER_ARM_M,
        description="Lever arm L of the balance scale (m); 0.162 m per Frohlich (2004).",
    )

    def com_offset_grip_m(self, mass_kg: float, handedness: Handedness) -> NDArray:
        """Center-of-mass offset (center -> center of mass) in the grip frame (m)."""
        h = handedness_sign(handedness)
        k = self.lever_arm_m * OZ_KG / (2.0 * mass_kg)
        return k * np.array([h * self.side_oz, self.finger_oz, self.top_oz])

    @classmethod
    def from_com_offset_grip(
        cls,
        offset_m: NDArray,
        mass_kg: float,
        handedness: Handedness,
        lever_arm_m: float = FROHLICH_LEVER_ARM_M,
    ) -> StaticWeights:
        """The scale readings that give ``offset_m`` (grip frame, m): inverse of
        :meth:`com_offset_grip_m`."""
        h = handedness_sign(handedness)
        k = 2.0 * mass_kg / (lever_arm_m * OZ_KG)
        x, y, z = (float(c) for c in offset_m)
        return cls(top_oz=k * z, side_oz=h * k * x, finger_oz=k * y, lever_arm_m=lever_arm_m)


class CenterOfMassMark(SpecModel):
    """The center of mass given as a surface position plus a scale reading along that axis.

    The center of mass lies on the ray from the center through the surface point ``over_in`` /
    ``up_in`` (grip-frame coordinates, module docstring), at distance L dm / (2 M) with dm =
    ``static_oz`` (the :class:`StaticWeights` balance model with the scale along that axis).
    """

    over_in: FiniteFloat = Field(description="Over from the center of grip, + toward the PAP (in).")
    up_in: FiniteFloat = Field(description="Up from the horizontal midline, + toward fingers (in).")
    static_oz: NonNegativeFloat = Field(description="Scale reading along that axis (oz).")
    lever_arm_m: PositiveFloat = Field(
        default=FROHLICH_LEVER_ARM_M, description="Lever arm L of the balance scale (m)."
    )

    def com_offset_grip_m(
        self, mass_kg: float, radius_in: float, handedness: Handedness
    ) -> NDArray:
        """Center-of-mass offset (center -> center of mass) in the grip frame (m)."""
        d = self.lever_arm_m * self.static_oz * OZ_KG / (2.0 * mass_kg)
        return d * grip_point(self.over_in, self.up_in, radius_in, handedness)

    def as_static_weights(
        self, mass_kg: float, radius_in: float, handedness: Handedness
    ) -> StaticWeights:
        """The same offset as top / side / finger readings."""
        off = self.com_offset_grip_m(mass_kg, radius_in, handedness)
        return StaticWeights.from_com_offset_grip(off, mass_kg, handedness, self.lever_arm_m)
