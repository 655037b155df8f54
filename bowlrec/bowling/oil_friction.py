"""Oil depth -> friction: an explicit, calibratable mapping mu(film thickness, coverstock,
surface), and the friction map of an oil pattern in the form the kernel evaluates (a
piecewise-constant grid, :class:`~bowlrec.spec.friction.GridFriction`).

**Oil depth** is the film thickness h (µm) of a grid cell: its oil volume over its area,
h = V / (dx dy) (1 µL per m^2 = 0.001 µm; 1 µL on a board-foot of a 41.5 in lane, 0.3048 m x
27.03 mm, is 0.1214 µm). No published friction-vs-oil curve is known (domain notes §6.3), so the
mapping is a two-level model with a ramp between them, every number a parameter:

    s(h) = 0                      if h <= dry_at_or_below_um
         = 1                      if h >= oiled_at_or_above_um (and h > dry_at_or_below_um)
         = (h - h0) / (h1 - h0)   in between (h0 = dry_at_or_below_um, h1 = oiled_at_or_above_um)
    mu(h, ball) = (1 - s(h)) D mu_dry + s(h) O mu_oil

or, with ``ramp: "power"``, s(h) = ((h - h0) / (h1 - h0)) ** ramp_exponent in between: the
browser simulator "Fresh Oil"'s mu = mu_dry - (mu_dry - mu_oil) f^0.40 with f = h / h1 for
h0 = 0 (a thin film does most of the work; ``docs/oil-transition.md``). A film worn below h1
then raises the friction, which a two-level map (h0 = h1) never does.

with D = dry cover factor x dry surface factor and O = oil cover factor x oil surface factor of
the ball (dimensionless). **The ball's factors** (``cover_model: "ranked"``, the default) come
from a sourced ranking of coverstocks and sanding grits with assumed numbers
(:mod:`bowlrec.bowling.surface`, ``docs/coverstock.md``); the reference ball, reactive_solid at
1000 grit (and a ball given without coverstock or surface), has D = O = 1 and sees mu_dry and
mu_oil unchanged. Entries of ``dry_factor`` / ``oil_factor`` replace a coverstock's ranked
factor; the grit model's numbers are fields too. ``cover_model: "none"`` makes every factor 1
except those entries: the same friction for every ball.

**Defaults are the calibration's** (:func:`~bowlrec.bowling.friction_levels.calibrated`:
fitted to published breakpoints, entry angles, roll points and a measured line,
``docs/calibration.md``): the reference ball's mu_oil and mu_dry, h0 = 0 and the power ramp up
to the calibrated full-oil film h1, so a cell with a film of h1 or more is at mu_oil, a dry
cell at mu_dry, and a thinner film between. :meth:`OilFrictionMapping.paper` gives the paper's
two levels instead (Frohlich 2004: 0.04 on any oil, 0.20 dry; ``oil_friction: "paper"`` in a
bowler scene). The paper's own scenes (:mod:`bowlrec.paper`) do not go through
this mapping.

**Positions outside the pattern's grid**: dry beyond the oil (x past its end, boards without
oil); behind the foul line (x < 0) and beyond the gutters (y < 0, y > width) the cells at the
lane's edge continue, so the lane's boundary adds no break point; break points at or beyond
the head pin (x >= length_m) are dropped (the run ends there). The grid is then minimal
(:func:`~bowlrec.spec.friction_grid.simplify_grid`): a pattern has only as many break points as
its oiled/dry boundary needs.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, ValidationInfo, field_validator

from bowlrec.spec._base import NonNegativeFloat, PositiveFloat, SpecModel, fmt, spec_error
from bowlrec.spec.friction import GridFriction
from bowlrec.spec.friction_grid import simplify_grid
from bowlrec.spec.lane import Lane
from bowlrec.units import BOARDS, FT_M, IN_M, LANE_LENGTH_FT, LANE_WIDTH_IN

from .friction_levels import PAPER, FrictionLevels, calibrated
from .oil import KegelPattern, OilGrid, RectanglePattern, oil_grid
from .surface import (
    COVER_FACTORS,
    COVERSTOCKS,
    GRIT_EXPONENT_DRY,
    GRIT_EXPONENT_OIL,
    GRIT_MAX,
    GRIT_MIN,
    POLISHED_DRY,
    POLISHED_OIL,
    REFERENCE_GRIT,
    Coverstock,
    Surface,
    check_surface,
    grit_factor,
    surface_text,
)

__all__ = [
    "COVERSTOCKS",
    "Coverstock",
    "CoverModel",
    "OilFrictionMapping",
    "Surface",
    "Ramp",
    "film_thickness_um",
    "grid_friction",
    "mirror_friction",
    "mu_of_film",
    "oiled_fraction",
    "pattern_friction",
    "pattern_lane",
]

Array = NDArray[np.float64]

#: "ranked": the sourced ranking's cover and surface factors; "none": every factor 1
CoverModel = Literal["ranked", "none"]
#: shape of s(h) between the dry and the oiled film: "linear" or "power" (module docstring)
Ramp = Literal["linear", "power"]

_USBC_WIDTH_M = LANE_WIDTH_IN * IN_M
_LANE_LENGTH_M = LANE_LENGTH_FT * FT_M


class OilFrictionMapping(SpecModel):
    """mu(film thickness, coverstock, surface); see the module docstring for the formula. The
    defaults give the calibrated levels (mu_oil wherever there is oil, mu_dry elsewhere) for
    the reference ball (reactive_solid at 1000 grit), and the ranked cover and surface factors
    for every other ball; :meth:`paper` the paper's 0.04 / 0.20."""

    mu_dry: NonNegativeFloat = Field(
        default=calibrated().mu_dry,
        description="Friction on a dry lane (>= 0), for the reference ball (default: the "
        "calibrated level, docs/calibration.md).",
    )
    mu_oil: NonNegativeFloat = Field(
        default=calibrated().mu_oil,
        description="Friction on full oil (>= 0), for the reference ball (default: the "
        "calibrated level, docs/calibration.md).",
    )
    dry_at_or_below_um: NonNegativeFloat = Field(
        default=0.0, description="Film thickness (µm) at or below which the lane is dry (>= 0)."
    )
    oiled_at_or_above_um: NonNegativeFloat = Field(
        default=calibrated().oiled_at_or_above_um,
        description="Film thickness (µm) from which the lane is fully oiled (>= the dry one); "
        "mu follows the ramp in between (default: the calibrated film, docs/calibration.md).",
    )
    ramp: Ramp = Field(
        default="power",
        description="Shape of the oiled fraction between the dry and the oiled film: 'linear', "
        "or 'power' ((h - h0) / (h1 - h0)) ** ramp_exponent (Fresh Oil's f^0.40).",
    )
    ramp_exponent: PositiveFloat = Field(
        default=0.4,
        le=10.0,
        description="Exponent of the 'power' ramp, in (0, 10] (Fresh Oil: 0.40; 1 is linear).",
    )
    cover_model: CoverModel = Field(
        default="ranked",
        description="'ranked': coverstock and surface grit scale the friction by the sourced "
        "ranking's assumed factors (docs/coverstock.md; reactive_solid at 1000 grit: factor 1); "
        "'none': every factor is 1 except the dry_factor / oil_factor entries.",
    )
    dry_factor: dict[Coverstock, PositiveFloat] = Field(
        default_factory=dict,
        description="Per coverstock: multiplies mu_dry, replacing the ranked factor "
        "(dimensionless).",
    )
    oil_factor: dict[Coverstock, PositiveFloat] = Field(
        default_factory=dict,
        description="Per coverstock: multiplies mu_oil, replacing the ranked factor "
        "(dimensionless).",
    )
    grit_reference: PositiveFloat = Field(
        default=float(REFERENCE_GRIT),
        ge=GRIT_MIN,
        le=GRIT_MAX,
        description=f"Grit whose surface factors are 1, in [{GRIT_MIN}, {GRIT_MAX}].",
    )
    grit_exponent_oil: NonNegativeFloat = Field(
        default=GRIT_EXPONENT_OIL.assumed,
        le=1.0,
        description="a in (grit / grit_reference) ** -a, the surface factor on mu_oil, in "
        f"[0, 1] (plausible {GRIT_EXPONENT_OIL.low:g}-{GRIT_EXPONENT_OIL.high:g}).",
    )
    grit_exponent_dry: NonNegativeFloat = Field(
        default=GRIT_EXPONENT_DRY.assumed,
        le=1.0,
        description="a in (grit / grit_reference) ** -a, the surface factor on mu_dry, in "
        f"[0, 1] (plausible {GRIT_EXPONENT_DRY.low:g}-{GRIT_EXPONENT_DRY.high:g}).",
    )
    polished_oil_factor: PositiveFloat = Field(
        default=POLISHED_OIL.assumed,
        description="Surface factor of a polished ball on mu_oil (> 0; plausible "
        f"{POLISHED_OIL.low:g}-{POLISHED_OIL.high:g}).",
    )
    polished_dry_factor: PositiveFloat = Field(
        default=POLISHED_DRY.assumed,
        description="Surface factor of a polished ball on mu_dry (> 0; plausible "
        f"{POLISHED_DRY.low:g}-{POLISHED_DRY.high:g}).",
    )

    @classmethod
    def with_levels(cls, levels: FrictionLevels, **fields: object) -> OilFrictionMapping:
        """A mapping at ``levels`` (the reference ball's mu_oil and mu_dry and the film from
        which a board is fully oiled), other fields from ``fields`` or their defaults."""
        return cls.model_validate(
            {
                "mu_oil": levels.mu_oil,
                "mu_dry": levels.mu_dry,
                "oiled_at_or_above_um": levels.oiled_at_or_above_um,
                **fields,
            }
        )

    @classmethod
    def paper(cls, **fields: object) -> OilFrictionMapping:
        """The paper's two levels (0.04 on oil, 0.20 dry) for the reference ball; other fields
        from ``fields`` or their defaults."""
        return cls.with_levels(PAPER, **fields)

    @field_validator("oiled_at_or_above_um")
    @classmethod
    def _ramp_ordered(cls, v: float, info: ValidationInfo) -> float:
        """oiled_at_or_above_um >= dry_at_or_below_um."""
        lo = info.data.get("dry_at_or_below_um")
        if lo is not None and v < lo:
            raise spec_error(
                f"oiled_at_or_above_um = {fmt(v)} must be >= dry_at_or_below_um = {fmt(lo)} "
                "(the lane cannot be fully oiled below the film at which it is dry)"
            )
        return v

    def cover_factors(self, coverstock: Coverstock | None) -> tuple[float, float]:
        """(dry, oil) factors of a coverstock (dimensionless): the explicit entry, else the
        ranked assumed factor ('ranked') or 1 ('none'); (1, 1) for None."""
        if coverstock is None:
            return 1.0, 1.0
        dry = oil = 1.0
        if self.cover_model == "ranked":
            ranked = COVER_FACTORS[coverstock]
            dry, oil = ranked.dry.assumed, ranked.oil.assumed
        return self.dry_factor.get(coverstock, dry), self.oil_factor.get(coverstock, oil)

    def surface_factors(self, surface: Surface | None) -> tuple[float, float]:
        """(dry, oil) factors of a surface (a grit number or 'polished'; dimensionless); (1, 1)
        for None and under cover_model 'none'. ValueError naming the value and the allowed
        grits for a grit outside [GRIT_MIN, GRIT_MAX]."""
        if surface is None or self.cover_model == "none":
            return 1.0, 1.0
        check_surface(surface)
        if surface == "polished":
            return self.polished_dry_factor, self.polished_oil_factor
        grit = float(surface)
        return (
            grit_factor(grit, self.grit_exponent_dry, self.grit_reference),
            grit_factor(grit, self.grit_exponent_oil, self.grit_reference),
        )

    def levels(
        self, coverstock: Coverstock | None = None, surface: Surface | None = None
    ) -> tuple[float, float]:
        """(mu_dry, mu_oil) for a ball's coverstock and surface (None: no factor)."""
        cover_dry, cover_oil = self.cover_factors(coverstock)
        surface_dry, surface_oil = self.surface_factors(surface)
        return cover_dry * surface_dry * self.mu_dry, cover_oil * surface_oil * self.mu_oil


def oiled_fraction(film_um: ArrayLike, mapping: OilFrictionMapping) -> Array:
    """s(h) in [0, 1]: 0 dry, 1 fully oiled (module docstring)."""
    h = np.asarray(film_um, dtype=np.float64)
    h0, h1 = mapping.dry_at_or_below_um, mapping.oiled_at_or_above_um
    if h1 == h0:
        return (h > h0).astype(np.float64)
    s = np.clip((h - h0) / (h1 - h0), 0.0, 1.0)
    if mapping.ramp == "power":
        return np.asarray(s**mapping.ramp_exponent, dtype=np.float64)
    return s


def mu_of_film(
    film_um: ArrayLike,
    mapping: OilFrictionMapping | None = None,
    coverstock: Coverstock | None = None,
    surface: Surface | None = None,
) -> Array:
    """Friction of film thicknesses (µm; a scalar or an array) for a ball's coverstock and
    surface (None: no factor)."""
    m = mapping or OilFrictionMapping()
    dry, oil = m.levels(coverstock, surface)
    s = oiled_fraction(np.asarray(film_um, dtype=np.float64), m)
    return dry * (1.0 - s) + oil * s  # exactly mu_dry at s = 0 and mu_oil at s = 1


def film_thickness_um(grid: OilGrid, lane_width_m: float) -> Array:
    """Film thickness (µm) of every cell of an oil grid on a lane ``lane_width_m`` wide (m)."""
    dx_m = np.diff(grid.x_edges_ft) * FT_M
    dy_m = np.diff(grid.board_edges) * (lane_width_m / BOARDS)
    volume_m3 = grid.volume_ul * 1e-9
    return volume_m3 / np.outer(dx_m, dy_m) * 1e6


def _board_edges_m(board_edges: Array, lane_width_m: float) -> Array:
    """Board positions (board widths from the right gutter) -> y (m); 0 and 39 map exactly to
    the gutters."""
    y = board_edges * lane_width_m / BOARDS
    return np.where(board_edges >= BOARDS, lane_width_m, y)


def _clamped(edges: Array, lo: float, hi: float) -> tuple[Array, slice]:
    """Edges strictly inside (lo, hi) and the slice of the padded cells they bound: a cell
    beyond ``lo`` / ``hi`` merges with the one inside."""
    first = int(np.searchsorted(edges, lo, side="right"))
    last = int(np.searchsorted(edges, hi, side="left"))
    return edges[first:last], slice(first, last + 1)


def pattern_friction(
    pattern: KegelPattern | RectanglePattern,
    *,
    lane_width_m: float,
    length_m: float = _LANE_LENGTH_M,
    coverstock: Coverstock | None = None,
    surface: Surface | None = None,
    mapping: OilFrictionMapping | None = None,
) -> GridFriction:
    """The friction map of an oil pattern on a lane ``lane_width_m`` wide and ``length_m`` long
    (m), for a ball's coverstock and surface (a grit number or 'polished'; None: no factor),
    under ``mapping`` (default: the paper's two levels for the reference ball, ranked factors
    for the others). Use the same width for the Lane (see :func:`pattern_lane`). ValueError
    for a grit outside the surface model's range."""
    m = mapping or OilFrictionMapping()
    return _friction_of_grid(
        oil_grid(pattern),
        lane_width_m,
        length_m,
        coverstock,
        surface,
        m,
        source=f"oil pattern {pattern.name!r}, {_mapping_text(m, coverstock, surface)}",
        name=pattern.name,
    )


def grid_friction(
    grid: OilGrid,
    *,
    lane_width_m: float,
    length_m: float = _LANE_LENGTH_M,
    coverstock: Coverstock | None = None,
    surface: Surface | None = None,
    mapping: OilFrictionMapping | None = None,
    name: str = "oil grid",
) -> GridFriction:
    """The friction map of any oil grid (e.g. a lane worn by a session's shots,
    :mod:`bowlrec.bowling.oil_transfer`) as :func:`pattern_friction` builds it for a pattern's
    grid: same mapping, same treatment of the lane's edges, the same minimal grid. ``name``
    labels the map (``GridFriction.pattern`` and its source)."""
    m = mapping or OilFrictionMapping()
    return _friction_of_grid(
        grid,
        lane_width_m,
        length_m,
        coverstock,
        surface,
        m,
        source=f"oil grid {name!r}, {_mapping_text(m, coverstock, surface)}",
        name=name,
    )


def _friction_of_grid(
    grid: OilGrid,
    lane_width_m: float,
    length_m: float,
    coverstock: Coverstock | None,
    surface: Surface | None,
    m: OilFrictionMapping,
    *,
    source: str,
    name: str,
) -> GridFriction:
    """The minimal GridFriction of ``grid`` under ``m`` (module docstring)."""
    film = np.pad(film_thickness_um(grid, lane_width_m), 1)  # dry all around the grid
    mu = mu_of_film(film, m, coverstock, surface)
    xe, xs = _clamped(grid.x_edges_ft * FT_M, 0.0, length_m)
    ye, ys = _clamped(_board_edges_m(grid.board_edges, lane_width_m), 0.0, lane_width_m)
    g = simplify_grid(xe, ye, mu[xs, ys])
    return GridFriction(
        x_edges_m=g.x_edges_m.tolist(),
        y_edges_m=g.y_edges_m.tolist(),
        mu=g.mu.tolist(),
        source=source,
        pattern=name,
    )


def _mapping_text(
    m: OilFrictionMapping, coverstock: Coverstock | None, surface: Surface | None
) -> str:
    """Short description of a mapping and ball for GridFriction.source."""
    ball = " at ".join(x for x in (coverstock or "no coverstock", surface_text(surface)) if x)
    dry, oil = m.levels(coverstock, surface)
    text = f"{ball}, mu_oil {oil:.4g} / mu_dry {dry:.4g}"
    if m.cover_model == "none":
        text += " (no cover model)"
    if m.oiled_at_or_above_um > 0:
        text += f", ramp {fmt(m.dry_at_or_below_um)}-{fmt(m.oiled_at_or_above_um)} um"
        if m.ramp == "power":
            text += f" (power {fmt(m.ramp_exponent)})"
    return text


def pattern_lane(
    pattern: KegelPattern | RectanglePattern,
    *,
    width_m: float = _USBC_WIDTH_M,
    length_m: float = _LANE_LENGTH_M,
    coverstock: Coverstock | None = None,
    surface: Surface | None = None,
    mapping: OilFrictionMapping | None = None,
) -> Lane:
    """A :class:`~bowlrec.spec.Lane` (default 60 ft x 41.5 in, USBC) oiled with ``pattern``,
    its friction for a ball's coverstock and surface (:func:`pattern_friction`); pass
    width_m=42 * 0.0254 for the paper's lane."""
    friction = pattern_friction(
        pattern,
        lane_width_m=width_m,
        length_m=length_m,
        coverstock=coverstock,
        surface=surface,
        mapping=mapping,
    )
    return Lane(length_m=length_m, width_m=width_m, friction=friction)


def mirror_friction(friction: GridFriction, width_m: float) -> GridFriction:
    """The map seen from the other side (y -> width_m - y), e.g. to simulate a left-hander as a
    mirrored right-hander. Cells stay half-open on the same side, so points exactly on a break
    point may change cell."""
    ye = [width_m - y for y in reversed(friction.y_edges_m)]
    mu = [list(reversed(row)) for row in friction.mu]
    return GridFriction(
        x_edges_m=list(friction.x_edges_m),
        y_edges_m=ye,
        mu=mu,
        source=friction.source,
        pattern=friction.pattern,
    )
