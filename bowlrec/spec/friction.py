"""Friction maps of the lane surface (dimensionless coefficients mu; positions in m, lane frame).

Three kinds, chosen by the field ``kind``:

* ``constant``: one mu everywhere;
* ``zones``: axis-aligned rectangles on a default; **later zones override earlier ones** where
  they overlap; zones may extend beyond the lane; a zone covers x in [x_min_m, x_max_m) and
  y in [y_min_m, y_max_m);
* ``typical``: the paper's Fig. 4 pattern: oil (``mu_oil``) over the central
  ``oil_width_fraction`` of the width for x < ``oil_length_m``, dry (``mu_dry``) elsewhere;
* ``grid``: an explicit piecewise-constant map in the grid convention of
  :mod:`bowlrec.spec.friction_grid` (sorted break points ``x_edges_m``, ``y_edges_m`` and one mu
  per cell, the outer cells unbounded), e.g. an oil pattern turned into friction by
  :func:`bowlrec.bowling.oil_friction.pattern_friction`.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, ValidationInfo, field_validator

from ._base import FiniteFloat, PositiveFloat, SpecModel, fmt, spec_error
from .limits import MAX_GRID_EDGES, MAX_MU, MAX_ZONES

#: a friction coefficient, in [0, MAX_MU]
Mu = Annotated[float, Field(ge=0, le=MAX_MU, allow_inf_nan=False)]

__all__ = [
    "ConstantFriction",
    "Friction",
    "GridFriction",
    "TypicalFriction",
    "Zone",
    "ZoneFriction",
]


class ConstantFriction(SpecModel):
    """The same friction coefficient over the whole surface."""

    kind: Literal["constant"] = "constant"
    mu: Mu = Field(description=f"Coefficient of sliding friction, in [0, {MAX_MU:g}].")


class Zone(SpecModel):
    """A rectangle x in [x_min_m, x_max_m), y in [y_min_m, y_max_m) (m) with friction ``mu``."""

    x_min_m: FiniteFloat
    x_max_m: FiniteFloat
    y_min_m: FiniteFloat
    y_max_m: FiniteFloat
    mu: Mu

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
    default_mu: Mu = Field(description=f"Friction outside every zone, in [0, {MAX_MU:g}].")
    zones: list[Zone] = Field(
        default_factory=list,
        max_length=MAX_ZONES,
        description=f"Rectangles painted in order (later ones win); at most {MAX_ZONES}.",
    )


class TypicalFriction(SpecModel):
    """The paper's typical oil pattern (Fig. 4): the central four-fifths of the lane oiled over
    all but the last 20 ft before the head pin."""

    kind: Literal["typical"] = "typical"
    mu_oil: Mu = Field(default=0.04, description=f"Friction on the oil, in [0, {MAX_MU:g}].")
    mu_dry: Mu = Field(default=0.20, description=f"Friction off the oil, in [0, {MAX_MU:g}].")
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


def _check_increasing(name: str, edges: list[float]) -> None:
    """Raise a spec error unless ``edges`` is strictly increasing."""
    for k in range(1, len(edges)):
        if not edges[k - 1] < edges[k]:
            raise spec_error(
                f"{name}[{k}] = {fmt(edges[k])} must be > {name}[{k - 1}] = "
                f"{fmt(edges[k - 1])} (break points must be strictly increasing)"
            )


class GridFriction(SpecModel):
    """An explicit piecewise-constant friction map (m; mu dimensionless).

    Cell (i, j) covers x in [x_edges_m[i-1], x_edges_m[i]) and y in [y_edges_m[j-1],
    y_edges_m[j]); the first and last cells along each axis are unbounded. So ``mu`` has
    len(x_edges_m) + 1 rows (x cells) of len(y_edges_m) + 1 entries (y cells); ``mu[0][0]`` is
    the cell with the smallest x and y (at the foul line, at the right gutter).
    """

    kind: Literal["grid"] = "grid"
    x_edges_m: list[FiniteFloat] = Field(
        default_factory=list,
        max_length=MAX_GRID_EDGES,
        description="Break points along the lane (m from the foul line), strictly increasing; "
        f"at most {MAX_GRID_EDGES}.",
    )
    y_edges_m: list[FiniteFloat] = Field(
        default_factory=list,
        max_length=MAX_GRID_EDGES,
        description="Break points across the lane (m from the right gutter), strictly "
        f"increasing; at most {MAX_GRID_EDGES}.",
    )
    mu: list[list[Mu]] = Field(
        description=(
            f"Friction per cell, in [0, {MAX_MU:g}]: len(x_edges_m) + 1 rows of "
            "len(y_edges_m) + 1 values; "
            "mu[i][j] is the cell after x_edges_m[i-1] and after y_edges_m[j-1]."
        )
    )
    source: str | None = Field(
        default=None, description="Free text: where the map comes from (e.g. an oil pattern)."
    )
    pattern: str | None = Field(
        default=None,
        description="Name of the oil pattern the map was made from (a preset name such as "
        "'kegel_chromium_6742', or a pattern sheet's name); archives index runs by it. A label: "
        "it does not change the physics or the run ID.",
    )

    @field_validator("x_edges_m", "y_edges_m")
    @classmethod
    def _edges_increasing(cls, v: list[float], info: ValidationInfo) -> list[float]:
        """Break points strictly increasing."""
        _check_increasing(info.field_name or "edges", v)
        return v

    @field_validator("mu")
    @classmethod
    def _mu_shape(cls, v: list[list[float]], info: ValidationInfo) -> list[list[float]]:
        """One row per x cell, one value per y cell."""
        xe, ye = info.data.get("x_edges_m"), info.data.get("y_edges_m")
        if xe is None or ye is None:  # already reported on the edges
            return v
        if len(v) != len(xe) + 1:
            raise spec_error(
                f"mu has {len(v)} rows; it must have len(x_edges_m) + 1 = {len(xe) + 1} "
                "(one row per x cell)"
            )
        for i, row in enumerate(v):
            if len(row) != len(ye) + 1:
                raise spec_error(
                    f"mu[{i}] has {len(row)} values; it must have len(y_edges_m) + 1 = "
                    f"{len(ye) + 1} (one value per y cell)"
                )
        return v


#: any friction map, discriminated by ``kind``
Friction = Annotated[
    ConstantFriction | ZoneFriction | TypicalFriction | GridFriction, Field(discriminator="kind")
]
