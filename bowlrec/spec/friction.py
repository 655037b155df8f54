"""Friction maps of the lane surface (dimensionless coefficients mu; positions in m, lane frame).

Three kinds, chosen by the field ``kind``:

* ``constant``: one mu everywhere;
* ``zones``: axis-aligned rectangles on a default; **later zones override earlier ones** where
  they overlap; zones may extend beyond the lane; a zone covers x in [x_min_m, x_max_m) and
  y in [y_min_m, y_max_m);
* ``typical``: the paper's Fig. 4 pattern: oil (``mu_oil``) over the central
  ``oil_width_fraction`` of the width for x < ``oil_length_m``, dry (``mu_dry``) elsewhere.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, ValidationInfo, field_validator

from ._base import FiniteFloat, NonNegativeFloat, PositiveFloat, SpecModel, fmt, spec_error

__all__ = ["ConstantFriction", "Friction", "TypicalFriction", "Zone", "ZoneFriction"]


class ConstantFriction(SpecModel):
    """The same friction coefficient over the whole surface."""

    kind: Literal["constant"] = "constant"
    mu: NonNegativeFloat = Field(description="Coefficient of sliding friction (>= 0).")


class Zone(SpecModel):
    """A rectangle x in [x_min_m, x_max_m), y in [y_min_m, y_max_m) (m) with friction ``mu``."""

    x_min_m: FiniteFloat
    x_max_m: FiniteFloat
    y_min_m: FiniteFloat
    y_max_m: FiniteFloat
    mu: NonNegativeFloat

    @field_validator("x_max_m", "y_max_m")
    @classmethod
    def _max_above_min(cls, v: float, info: ValidationInfo) -> float:
        """x_min_m < x_max_m and y_min_m < y_max_m."""
        axis = info.field_name[0] if info.field_name else "?"
        lo = info.data.get(f"{axis}_min_m")
        if lo is not None and not lo < v:
            raise spec_error(
                f"{axis}_min_m = {fmt(lo)} must be < {axis}_max_m = {fmt(v)} "
                "(a zone must have a positive extent)"
            )
        return v


class ZoneFriction(SpecModel):
    """``default_mu`` everywhere except in ``zones``; later zones override earlier ones."""

    kind: Literal["zones"] = "zones"
    default_mu: NonNegativeFloat = Field(description="Friction outside every zone (>= 0).")
    zones: list[Zone] = Field(
        default_factory=list, description="Rectangles painted in order (later ones win)."
    )


class TypicalFriction(SpecModel):
    """The paper's typical oil pattern (Fig. 4): the central four-fifths of the lane oiled over
    all but the last 20 ft before the head pin."""

    kind: Literal["typical"] = "typical"
    mu_oil: NonNegativeFloat = Field(default=0.04, description="Friction on the oil (>= 0).")
    mu_dry: NonNegativeFloat = Field(default=0.20, description="Friction off the oil (>= 0).")
    oil_length_m: PositiveFloat = Field(
        default=12.192,
        description="Oil covers x < oil_length_m (m); 12.192 m = 40 ft = 60 ft - 20 ft.",
    )
    oil_width_fraction: float = Field(
        default=0.8,
        gt=0,
        le=1,
        allow_inf_nan=False,
        description="Oiled fraction of the width, centered across the lane, in (0, 1].",
    )


#: any friction map, discriminated by ``kind``
Friction = Annotated[ConstantFriction | ZoneFriction | TypicalFriction, Field(discriminator="kind")]
