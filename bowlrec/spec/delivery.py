"""The delivery: where and how the ball leaves the bowler's hand (m, m/s, deg, rad/s).

Speed and direction are those of the ball's **geometric center** (what a tracking system sees).
With a center-of-mass offset the center of mass then starts at v - omega x r_Delta (r_Delta: the
vector from the center of mass to the center); this choice moves the hook by about 6 mm for a
0.7 mm offset compared with giving the velocity of the center of mass.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from ._base import FiniteFloat, PositiveFloat, SpecModel, Vec2
from .limits import MAX_OMEGA_RADPS, MAX_SPEED_MPS

#: one component of the angular velocity (rad/s), |value| <= MAX_OMEGA_RADPS
SpinComponent = Annotated[
    float, Field(ge=-MAX_OMEGA_RADPS, le=MAX_OMEGA_RADPS, allow_inf_nan=False)
]

__all__ = ["Delivery"]


class Delivery(SpecModel):
    """Initial state of the ball (lane frame, SI; the take-off angle in degrees)."""

    position_m: Vec2 | None = Field(
        default=None,
        description=(
            "Initial (x, y) of the geometric center (m); null = (0, lane.width_m / 2), the lane "
            "center on the foul line. Must be on the lane."
        ),
    )
    speed_mps: PositiveFloat = Field(
        default=8.0,
        le=MAX_SPEED_MPS,
        description=f"Speed of the geometric center (m/s), in (0, {MAX_SPEED_MPS:g}].",
    )
    takeoff_angle_deg: FiniteFloat = Field(
        default=0.0,
        gt=-90,
        lt=90,
        description=(
            "Angle of the velocity to the x axis (deg), positive toward the left (+y); "
            "in (-90, 90)."
        ),
    )
    omega_radps: tuple[SpinComponent, SpinComponent, SpinComponent] = Field(
        default=(0.0, 30.0, 0.0),
        description=(
            "Angular velocity in the lane frame (rad/s); (0, w, 0) with w > 0 is forward roll. "
            f"Each component in [-{MAX_OMEGA_RADPS:g}, {MAX_OMEGA_RADPS:g}]."
        ),
    )
