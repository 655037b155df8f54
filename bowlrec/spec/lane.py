"""The lane: its extent (m), its friction map, its rolling resistance and its topography."""

from __future__ import annotations

from pydantic import Field, model_validator

from ._base import FiniteFloat, NonNegativeFloat, PositiveFloat, SpecModel, Vec2, fmt, spec_error
from .friction import Friction, TypicalFriction
from .limits import MAX_LANE_M, MAX_PROFILE_POINTS, MAX_ROLLING_RESISTANCE, MAX_SLOPE

__all__ = ["Lane", "Topography"]


class Topography(SpecModel):
    """The lane's height across it, in the small-slope approximation: gravity's lateral
    component -g dz/dy acts at the ball's center of mass, the contact geometry stays flat (the
    normal along z). The paper's lane is flat; its exactness claims hold for flat lanes only.

    dz/dy is ``cross_slope`` plus the slope of the natural cubic spline through ``profile_m``;
    their sum may not exceed MAX_SLOPE in size anywhere on the profile (and, beyond its ends,
    where the spline continues straight)."""

    cross_slope: FiniteFloat = Field(
        default=0.0,
        ge=-MAX_SLOPE,
        le=MAX_SLOPE,
        description=(
            f"Tilt across the lane dz/dy (dimensionless, m per m), in [-{MAX_SLOPE:g}, "
            f"{MAX_SLOPE:g}]; > 0: the left side (+y) is higher and the ball drifts right. "
            "USBC allows 0.040 in over the 41.5 in lane: 9.6e-4."
        ),
    )
    profile_m: list[Vec2] | None = Field(
        default=None,
        description=(
            "Height profile across the lane: points (y, z) in m, y strictly ascending, "
            f"2 to {MAX_PROFILE_POINTS} points, joined by a natural cubic spline (continued "
            "straight beyond the ends); a crown (z higher in the middle) or a depression. "
            "Heights are relative: only their slope acts."
        ),
    )

    @model_validator(mode="after")
    def _slopes_small(self) -> Topography:
        """Profile points ascending, and |dz/dy| <= MAX_SLOPE everywhere."""
        from bowlrec.core.topography import max_abs_slope

        pts = self.profile_m
        if pts is None:
            return self
        if not 2 <= len(pts) <= MAX_PROFILE_POINTS:
            raise spec_error(f"profile_m has {len(pts)} points; it needs 2 to {MAX_PROFILE_POINTS}")
        for k in range(1, len(pts)):
            if not pts[k][0] > pts[k - 1][0]:
                raise spec_error(
                    f"profile_m[{k}] y = {fmt(pts[k][0])} must be greater than profile_m"
                    f"[{k - 1}] y = {fmt(pts[k - 1][0])} (y strictly ascending, m)"
                )
        ys = [p[0] for p in pts]
        zs = [p[1] for p in pts]
        slope, where = max_abs_slope(self.cross_slope, ys, zs)  # type: ignore[arg-type]
        if not slope <= MAX_SLOPE:
            raise spec_error(
                f"cross_slope + the slope of profile_m = {slope:.4g} at y = {where:.4g} m; "
                f"|dz/dy| must be in [0, {MAX_SLOPE:g}] (the small-slope approximation)"
            )
        return self


class Lane(SpecModel):
    """A lane from the foul line (x = 0) to the head pin (x = length_m), from the right gutter
    (y = 0) to the left one (y = width_m)."""

    length_m: PositiveFloat = Field(
        default=18.288,
        le=MAX_LANE_M,
        description=f"Foul line to head pin (m), in (0, {MAX_LANE_M:g}]; 18.288 m = 60 ft.",
    )
    width_m: PositiveFloat = Field(
        default=1.0668,
        le=MAX_LANE_M,
        description=f"Width (m), in (0, {MAX_LANE_M:g}]; 1.0668 m = 42 in, the paper's value.",
    )
    friction: Friction = Field(
        default_factory=lambda: TypicalFriction(),
        description="Friction map (discriminated by 'kind').",
    )
    # the optional terms' fields are left out of the scene's JSON at their defaults, so scenes
    # without them serialize (and are archived) as they do without these fields
    rolling_resistance: NonNegativeFloat = Field(
        default=0.0,
        le=MAX_ROLLING_RESISTANCE,
        exclude_if=lambda v: v == 0.0,
        description=(
            "Rolling-resistance coefficient C_rr (dimensionless), in [0, "
            f"{MAX_ROLLING_RESISTANCE:g}]: a force C_rr M g against the motion of the ball's "
            "center (the normal force acting C_rr R ahead of the contact); 0: none (the "
            "paper's assumption)."
        ),
    )
    topography: Topography | None = Field(
        default=None,
        exclude_if=lambda v: v is None,
        description="Cross tilt and height profile across the lane; null: a flat lane.",
    )
