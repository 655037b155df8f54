"""The lane: its extent (m) and its friction map."""

from __future__ import annotations

from pydantic import Field

from ._base import PositiveFloat, SpecModel
from .friction import Friction, TypicalFriction
from .limits import MAX_LANE_M

__all__ = ["Lane"]


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
