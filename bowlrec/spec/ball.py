"""The ball: mass, size, principal radii of gyration, weight-block orientation, center-of-mass
offset. Units: kg, m; directions are dimensionless vectors in the lane frame at release.

Sign convention of the center-of-mass offset (read this):

* ``com_offset_m`` is the vector FROM the ball's geometric center TO its center of mass, in the
  lane frame at release. That is what a ball driller measures ("the weight is toward the
  pin / the PAP / ...").
* The paper's r_Delta (Frohlich 2004, Fig. 1 and Eqs. (6)-(7)) is the vector FROM the center of
  mass TO the geometric center, so **r_Delta = -com_offset_m**. The resolved
  :class:`~bowlrec.core.plan.Plan` stores r_Delta (in the body frame).
* Table III's "offset parallel to omega_0" (case 4) therefore means ``com_offset_m`` along
  +omega_0, i.e. the center of mass sits on the left side of a forward-rolling ball.
"""

from __future__ import annotations

import math

from pydantic import Field, ValidationInfo, field_validator, model_validator

from ._base import (
    PositiveFloat,
    PositiveVec3,
    Quat,
    SpecModel,
    Vec3,
    fmt,
    fmt_vec,
    norm,
    spec_error,
)
from .limits import MAX_MASS_KG, MAX_RADIUS_M, MIN_RG_FRACTION

__all__ = ["Ball", "PERPENDICULAR_TOLERANCE", "ZERO_LENGTH"]

#: |cos(angle)| between the normalized axes above which axis_2 is "not perpendicular" to axis_1
PERPENDICULAR_TOLERANCE = 1e-9
#: vectors shorter than this are treated as zero-length (their direction is undefined)
ZERO_LENGTH = 1e-12
#: relative slack of the triangle-inequality check (rounding of rg**2 only)
_TRIANGLE_SLACK = 1e-12


def _check_direction(name: str, v: tuple[float, ...]) -> None:
    """Raise when ``v`` cannot be normalized."""
    n = norm(v)
    if not n > ZERO_LENGTH:
        raise spec_error(
            f"{name} = {fmt_vec(v)} has length {fmt(n)}; it must be a nonzero vector "
            f"(length > {ZERO_LENGTH:g}) because only its direction is used"
        )


class Ball(SpecModel):
    """A bowling ball as a rigid body (SI units).

    The body frame is the ball's principal-axes frame: ``rg_m[i]`` is the radius of gyration
    about principal axis i+1, so the principal moments are I_i = mass_kg * rg_m[i]**2 (kg m^2).
    The orientation at release is given either by the lane-frame directions of principal axes 1
    and 2 (``axis_1``, ``axis_2``; axis 3 = axis_1 x axis_2) or by a unit quaternion
    ``orientation_wxyz`` (body -> lane), not both.
    """

    mass_kg: PositiveFloat = Field(
        default=6.8,
        le=MAX_MASS_KG,
        description=(
            f"Mass (kg), in (0, {MAX_MASS_KG:g}]. The kinematics of the paper's scenes do not "
            "depend on it."
        ),
    )
    radius_m: PositiveFloat = Field(
        default=0.1085,
        le=MAX_RADIUS_M,
        description=f"Radius R of the ball (m), in (0, {MAX_RADIUS_M:g}].",
    )
    rg_m: PositiveVec3 = Field(
        default=(0.067, 0.067, 0.067),
        validate_default=True,
        description=(
            "Radii of gyration about principal axes 1, 2, 3 (m); each in [radius_m / 1000, "
            "radius_m) and the moments m*rg_i**2 must satisfy the triangle inequalities."
        ),
    )
    axis_1: Vec3 = Field(
        default=(1.0, 0.0, 0.0),
        description=(
            "Direction of principal axis 1 in the lane frame at release (normalized on resolve). "
            "Must be left at its default when orientation_wxyz is given."
        ),
    )
    axis_2: Vec3 | None = Field(
        default=None,
        description=(
            "Direction of principal axis 2 in the lane frame at release, perpendicular to axis_1 "
            "(normalized on resolve). May be omitted only when rg_m[1] == rg_m[2]; a "
            "perpendicular is then picked deterministically."
        ),
    )
    orientation_wxyz: Quat | None = Field(
        default=None,
        description=(
            "Orientation at release as a quaternion (w, x, y, z) rotating body vectors into the "
            "lane frame (normalized on resolve). Alternative to axis_1/axis_2."
        ),
    )
    com_offset_m: Vec3 = Field(
        default=(0.0, 0.0, 0.0),
        validate_default=True,
        description=(
            "Vector FROM the geometric center TO the center of mass, lane frame at release (m). "
            "The paper's r_Delta is its negative. |com_offset_m| < radius_m."
        ),
    )

    @field_validator("rg_m")
    @classmethod
    def _rg_physical(
        cls, rg: tuple[float, float, float], info: ValidationInfo
    ) -> tuple[float, float, float]:
        """Each radius of gyration < radius; principal moments satisfy the triangle inequality."""
        radius = info.data.get("radius_m")
        if radius is not None:
            for i, k in enumerate(rg):
                if not k < radius:
                    raise spec_error(
                        f"rg_m[{i}] = {fmt(k)} must be < radius_m = {fmt(radius)} (a radius of "
                        "gyration cannot exceed the radius for a body inside the sphere)"
                    )
                if k < radius * MIN_RG_FRACTION:
                    raise spec_error(
                        f"rg_m[{i}] = {fmt(k)} must be at least radius_m / "
                        f"{1 / MIN_RG_FRACTION:g} = {radius * MIN_RG_FRACTION:.4g} m (a ball "
                        "nearly all of whose mass sits at its centre makes the slip too stiff "
                        "to integrate; a uniform sphere's is 0.63 radius_m)"
                    )
        mass = info.data.get("mass_kg", 1.0)
        moments = [mass * k * k for k in rg]
        for c in range(3):
            a, b = (i for i in range(3) if i != c)
            lo, hi = abs(moments[a] - moments[b]), moments[a] + moments[b]
            if moments[c] > hi * (1.0 + _TRIANGLE_SLACK):
                k_max = math.sqrt(rg[a] ** 2 + rg[b] ** 2)
                raise spec_error(
                    f"rg_m = {fmt_vec(rg)} violates the triangle inequality of principal "
                    f"moments: I_{a + 1} + I_{b + 1} = {hi:.6g} kg m^2 < I_{c + 1} = "
                    f"{moments[c]:.6g} kg m^2 (I_i = mass_kg * rg_m[i-1]**2); I_{c + 1} must be "
                    f"in [{lo:.6g}, {hi:.6g}] kg m^2, i.e. rg_m[{c}] <= "
                    f"sqrt(rg_m[{a}]**2 + rg_m[{b}]**2) = {k_max:.6g} m"
                )
        return rg

    @field_validator("axis_1")
    @classmethod
    def _axis_1_nonzero(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        """axis_1 must have a direction."""
        _check_direction("axis_1", v)
        return v

    @field_validator("axis_2")
    @classmethod
    def _axis_2_perpendicular(
        cls, v: tuple[float, float, float] | None, info: ValidationInfo
    ) -> tuple[float, float, float] | None:
        """axis_2 must have a direction perpendicular to axis_1."""
        if v is None:
            return v
        _check_direction("axis_2", v)
        a1 = info.data.get("axis_1")
        if a1 is None:  # axis_1 itself was invalid and is reported separately
            return v
        n1, n2 = norm(a1), norm(v)
        cos = sum((x / n1) * (y / n2) for x, y in zip(a1, v, strict=True))
        if abs(cos) > PERPENDICULAR_TOLERANCE:
            angle = math.degrees(math.acos(max(-1.0, min(1.0, cos))))
            raise spec_error(
                f"axis_2 = {fmt_vec(v)} is at {angle:.10g} deg to axis_1 = {fmt_vec(a1)}; "
                f"principal axes must be perpendicular (|cos(angle)| <= "
                f"{PERPENDICULAR_TOLERANCE:g}, got {abs(cos):.3g})"
            )
        return v

    @field_validator("orientation_wxyz")
    @classmethod
    def _quaternion_nonzero(
        cls, q: tuple[float, float, float, float] | None
    ) -> tuple[float, float, float, float] | None:
        """The quaternion must be normalizable."""
        if q is not None and not norm(q) > ZERO_LENGTH:
            raise spec_error(
                f"orientation_wxyz = {fmt_vec(q)} has length {fmt(norm(q))}; it must be a "
                f"nonzero quaternion (length > {ZERO_LENGTH:g}; it is normalized on resolve)"
            )
        return q

    @field_validator("com_offset_m")
    @classmethod
    def _offset_inside(
        cls, v: tuple[float, float, float], info: ValidationInfo
    ) -> tuple[float, float, float]:
        """The center of mass must lie inside the ball."""
        radius = info.data.get("radius_m")
        if radius is not None and not norm(v) < radius:
            raise spec_error(
                f"com_offset_m = {fmt_vec(v)} has length {fmt(norm(v))} m; it must be < "
                f"radius_m = {fmt(radius)} (the center of mass lies inside the ball)"
            )
        return v

    @model_validator(mode="after")
    def _orientation_complete(self) -> Ball:
        """Exactly one way of giving the orientation; axis_2 when the high-RG axes differ."""
        default_axis_1 = type(self).model_fields["axis_1"].default
        if self.orientation_wxyz is not None:
            if self.axis_2 is not None or tuple(self.axis_1) != default_axis_1:
                raise spec_error(
                    f"orientation_wxyz = {fmt_vec(self.orientation_wxyz)} is mutually exclusive "
                    f"with axis_1 = {fmt_vec(self.axis_1)} / axis_2 = "
                    f"{None if self.axis_2 is None else fmt_vec(self.axis_2)}; give either the "
                    f"quaternion (leaving axis_1 at its default {fmt_vec(default_axis_1)} and "
                    "axis_2 null) or the axes"
                )
            return self
        if self.axis_2 is None and self.rg_m[1] != self.rg_m[2]:
            raise spec_error(
                f"axis_2 is required when rg_m[1] != rg_m[2] (rg_m = {fmt_vec(self.rg_m)}): "
                "the orientation of principal axes 2 and 3 about axis_1 matters"
            )
        return self

    @property
    def principal_moments_kg_m2(self) -> tuple[float, float, float]:
        """Principal moments I_i = mass_kg * rg_m[i]**2 (kg m^2)."""
        m = self.mass_kg
        return (m * self.rg_m[0] ** 2, m * self.rg_m[1] ** 2, m * self.rg_m[2] ** 2)
