"""The tenpin: its profile, its mass properties and its convex pieces.

**The profile** is the pin's radius r(z) at height z above its base (inches in the table, metres
in the API). Published points (USBC specification as quoted by the sources in
``../shared/domain-notes.md`` §5.1): height 15 in; base diameter about 2.03 in; the belly,
4.766 in wide at 4.5 in; the neck, about 1.8 in wide at about 10 in; the head a uniform arc of
radius 1.273 in ending at the top (so the head is 2.546 in wide, the published "about 2.55 in",
at 15 - 1.273 in). Between them the profile is bowlrec's own: a monotone cubic (PCHIP) through
the shape points of :data:`PROFILE_POINTS_IN`, whose intermediate stations were chosen to follow
the pin's drawn shape; they are not a published table. The solid of revolution of this profile,
filled uniformly, has its centre of gravity at 5.81 in, inside USBC's 5 40/64 - 5 60/64 in
(5.625 - 5.9375 in), which is the check that the shape carries its mass where a pin does.

**Mass properties** (:func:`mass_properties`): volume, centre of gravity and moments of inertia
of that solid by quadrature on 20,001 heights (exact to ~1e-9 relative for the cubic), with the
density that gives the pin's mass. A pin whose mass or centre of gravity is drawn within the
tolerances (:mod:`bowlrec.pins.deck`) keeps the profile's moments, moved to its centre of
gravity by the parallel-axis theorem.

**Convex pieces** (:func:`convex_pieces`): a pin is not convex (its neck), and MuJoCo collides
convex shapes. Over a height range where r(z) is concave the solid of revolution is convex, so
the pin is cut at the heights where r'' changes sign and at the neck, and each piece is the
convex hull of rings of the profile (a polygon of :data:`RING_SIDES` sides per ring with the
ring's area, so that the pieces hold the solid's volume: the polygon's corners stand 0.65 %
outside the circle and its edges' middles 1.3 % inside). The tests bound the volume the hulls add.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from scipy.interpolate import PchipInterpolator

from bowlrec.units import IN_M, LB_KG, OZ_KG

__all__ = [
    "CG_RANGE_M",
    "HEIGHT_M",
    "MASS_RANGE_KG",
    "PROFILE_POINTS_IN",
    "RING_SIDES",
    "MassProperties",
    "base_radius_m",
    "convex_pieces",
    "mass_properties",
    "radius_m",
    "tipping_angle_rad",
]

#: pin height (m): 15 in
HEIGHT_M = 15.0 * IN_M
#: radius of the head's arc (m): 1.273 in
HEAD_ARC_M = 1.273 * IN_M
#: USBC weight range (kg): 3 lb 6 oz - 3 lb 10 oz
MASS_RANGE_KG = (3 * LB_KG + 6 * OZ_KG, 3 * LB_KG + 10 * OZ_KG)
#: USBC centre-of-gravity range above the base (m): 5 40/64 - 5 60/64 in
CG_RANGE_M = ((5 + 40 / 64) * IN_M, (5 + 60 / 64) * IN_M)

#: (height, diameter) in inches: the published points (0, 2.03), (4.5, 4.766), (10, 1.797) and
#: the head arc, and bowlrec's intermediate shape points between them
PROFILE_POINTS_IN: tuple[tuple[float, float], ...] = (
    (0.0, 2.030),
    (0.75, 2.828),
    (2.25, 3.906),
    (3.375, 4.510),
    (4.5, 4.766),
    (5.875, 4.563),
    (7.25, 3.703),
    (8.625, 2.472),
    (9.375, 1.965),
    (10.0, 1.797),
    (10.875, 1.870),
    (11.75, 2.094),
    (12.375, 2.406),
    (15.0 - 1.273, 2 * 1.273),
)
#: sides of the polygon that stands for each ring of a convex piece
RING_SIDES = 16
#: heights (in) where the pin is cut into convex pieces: where r'' changes sign and at the neck
_CUTS_IN = (0.0, 6.6, 8.2, 9.2, 10.0, 11.9, 15.0)
#: rings per inch of height in a piece
_RINGS_PER_IN = 4


@cache
def _interpolant() -> PchipInterpolator:
    from scipy.interpolate import PchipInterpolator

    z = np.array([p[0] for p in PROFILE_POINTS_IN]) * IN_M
    r = np.array([p[1] for p in PROFILE_POINTS_IN]) * IN_M / 2.0
    return PchipInterpolator(z, r)


def radius_m(z_m: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """The pin's radius (m) at height ``z_m`` (m) above its base; 0 outside [0, 15 in]."""
    z = np.asarray(z_m, dtype=np.float64)
    pchip = _interpolant()
    z_arc = HEIGHT_M - HEAD_ARC_M
    lower = pchip(np.clip(z, 0.0, z_arc))
    upper = np.sqrt(np.maximum(HEAD_ARC_M**2 - (z - z_arc) ** 2, 0.0))
    r = np.where(z <= z_arc, lower, upper)
    return np.where((z < 0.0) | (z > HEIGHT_M), 0.0, r)


def base_radius_m() -> float:
    """Radius of the pin's base (m): half of 2.03 in."""
    return float(radius_m(0.0))


@dataclass(frozen=True)
class MassProperties:
    """A pin's mass properties: mass (kg), centre of gravity above the base (m), moments of
    inertia about the centre of gravity (kg m^2): axial (about the pin's axis) and transverse
    (about any horizontal axis through the centre of gravity of the standing pin)."""

    mass_kg: float
    cg_height_m: float
    axial_kgm2: float
    transverse_kgm2: float
    volume_m3: float
    density_kg_m3: float


@cache
def _profile_moments() -> tuple[float, float, float, float]:
    """Volume (m^3), first moment (m^4), and per-unit-density I_axial and I_about_base
    (kg m^2 per kg/m^3) of the uniform solid."""
    z = np.linspace(0.0, HEIGHT_M, 20_001)
    r = radius_m(z)
    area = np.pi * r**2
    volume = float(np.trapezoid(area, z))
    first = float(np.trapezoid(area * z, z))
    axial = float(np.trapezoid(np.pi * r**4 / 2.0, z))
    # a disc of radius r at height z about a horizontal axis through the base: r^2/4 + z^2
    about_base = float(np.trapezoid(area * (r**2 / 4.0 + z**2), z))
    return volume, first, axial, about_base


def mass_properties(
    mass_kg: float | None = None, cg_height_m: float | None = None
) -> MassProperties:
    """The pin's mass properties: the uniform solid of the profile scaled to ``mass_kg``
    (default: the middle of USBC's range, 3 lb 8 oz); ``cg_height_m`` (default: the solid's
    own) moves the centre of gravity, the moments kept about it."""
    volume, first, axial, about_base = _profile_moments()
    mass = sum(MASS_RANGE_KG) / 2.0 if mass_kg is None else mass_kg
    density = mass / volume
    own_cg = first / volume
    transverse = density * about_base - mass * own_cg**2
    return MassProperties(
        mass_kg=mass,
        cg_height_m=own_cg if cg_height_m is None else cg_height_m,
        axial_kgm2=density * axial,
        transverse_kgm2=transverse,
        volume_m3=volume,
        density_kg_m3=density,
    )


def tipping_angle_rad(cg_height_m: float | None = None) -> float:
    """The tilt past which a pin resting on its base edge falls (rad): atan(base radius / CG
    height)."""
    cg = mass_properties().cg_height_m if cg_height_m is None else cg_height_m
    return math.atan2(base_radius_m(), cg)


@cache
def convex_pieces() -> tuple[NDArray[np.float64], ...]:
    """The pin's convex pieces as vertex arrays (n, 3) in metres, in the pin's frame (z up
    along the axis, base centre at the origin); each the hull of rings of the profile."""
    pieces = []
    # the regular polygon with the circle's area: n r'^2 sin(2 pi / n) / 2 = pi r^2
    equal_area = math.sqrt(2.0 * math.pi / (RING_SIDES * math.sin(2.0 * math.pi / RING_SIDES)))
    angles = 2.0 * math.pi * np.arange(RING_SIDES) / RING_SIDES
    for lo, hi in zip(_CUTS_IN[:-1], _CUTS_IN[1:], strict=True):
        n_rings = max(2, int(math.ceil((hi - lo) * _RINGS_PER_IN)) + 1)
        heights = np.linspace(lo, hi, n_rings) * IN_M
        verts = []
        for z in heights:
            r = float(radius_m(z))
            if r <= 0.0:
                verts.append((0.0, 0.0, float(z)))
                continue
            rr = r * equal_area
            verts += [(rr * math.cos(a), rr * math.sin(a), float(z)) for a in angles]
        pieces.append(np.array(verts, dtype=np.float64))
    return tuple(pieces)
