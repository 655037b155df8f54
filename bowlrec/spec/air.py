"""The air around the ball: drag and Magnus lift (both off by default; the paper leaves them
out, noting in its footnote 15 that drag slows a ball by a few per cent over the lane)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ._base import PositiveFloat, SpecModel
from .limits import MAX_AIR_DENSITY, MAX_DRAG_COEFFICIENT

__all__ = ["Air"]


class Air(SpecModel):
    """Still air: drag F = C_D rho A |v| v / 2 against the velocity v of the ball's center and,
    with ``magnus``, a lift C_L(S) rho A |v|^2 / 2 along w x v (A = pi R^2, S = R |w_perp| / |v|),
    both applied at the geometric center (docs/lane-and-air.md)."""

    drag: bool = Field(default=False, description="Apply air drag.")
    drag_coefficient: PositiveFloat = Field(
        default=0.47,
        le=MAX_DRAG_COEFFICIENT,
        description=(
            f"Drag coefficient C_D (dimensionless), in (0, {MAX_DRAG_COEFFICIENT:g}]; 0.47: a "
            "sphere at Reynolds numbers 1e3-2e5 (a bowling ball at 1-9 m/s: Re 1.4e4-1.3e5)."
        ),
    )
    density_kg_m3: PositiveFloat = Field(
        default=1.204,
        le=MAX_AIR_DENSITY,
        description=(
            f"Density of the air (kg/m^3), in (0, {MAX_AIR_DENSITY:g}]; 1.204: dry air at "
            "20 C and sea level."
        ),
    )
    magnus: bool = Field(default=False, description="Apply the Magnus lift of the spin.")
    lift_model: Literal["sawicki2003"] = Field(
        default="sawicki2003",
        description=(
            "Lift coefficient C_L(S): sawicki2003 = Sawicki, Hubbard & Stronge, Am. J. Phys. "
            "71, 1152 (2003): 1.5 S for S <= 0.1, 0.09 + 0.6 S above."
        ),
    )
