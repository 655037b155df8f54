"""A complete scene: ball, lane, delivery and options, plus its resolution to a Plan."""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field, ValidationInfo, field_validator

from ._base import SpecModel, fmt, spec_error
from .air import Air
from .ball import Ball
from .delivery import Delivery
from .lane import Lane
from .options import Options

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan

__all__ = ["Scene"]


class Scene(SpecModel):
    """One delivery of one ball on one lane, in SI units (see each part for its fields).

    ``Scene()`` is a uniform 6.8 kg ball rolled forward at 8 m/s, 30 rad/s from the lane center
    on the paper's typical oil pattern.
    """

    name: str = Field(
        default="scene",
        max_length=200,
        description="Short identifier (at most 200 characters), carried to the results.",
    )
    description: str = Field(default="", description="Free text.")
    ball: Ball = Field(default_factory=lambda: Ball())
    lane: Lane = Field(default_factory=lambda: Lane())
    delivery: Delivery = Field(default_factory=lambda: Delivery())
    options: Options = Field(default_factory=lambda: Options())
    air: Air = Field(
        default_factory=lambda: Air(),
        exclude_if=lambda v: v == Air(),  # left out of the JSON when all off (as before it existed)
        description="Air drag and Magnus lift (both off by default).",
    )

    @field_validator("delivery")
    @classmethod
    def _release_on_lane(cls, delivery: Delivery, info: ValidationInfo) -> Delivery:
        """The release point must be on the lane: 0 <= x < length_m, 0 <= y <= width_m."""
        lane = info.data.get("lane")
        if lane is None or delivery.position_m is None:
            return delivery
        x, y = delivery.position_m
        if not 0.0 <= x < lane.length_m:
            raise spec_error(
                f"position_m[0] = x = {fmt(x)} must be in [0, lane.length_m = "
                f"{fmt(lane.length_m)}) (the release point must be on the lane)"
            )
        if not 0.0 <= y <= lane.width_m:
            raise spec_error(
                f"position_m[1] = y = {fmt(y)} must be in [0, lane.width_m = "
                f"{fmt(lane.width_m)}] (the release point must be on the lane)"
            )
        return delivery

    def resolve(self) -> Plan:
        """The plain-number :class:`~bowlrec.core.plan.Plan` the simulator consumes."""
        from .resolve import resolve_scene

        return resolve_scene(self)
