"""The pin deck: the ten spots, the deck, the gutters beside it, the kickbacks and the pit, and
the pins as set on a given shot (their tolerances drawn from a seed).

Lane frame (m): x from the foul line toward the pins, y from the right gutter toward the left,
z up with the lane's surface at z = 0 here (the deck's own frame; the ball's kernel frame has
its centre plane at z = 0, so a kernel z is this z minus the ball's radius).

Dimensions (``../shared/domain-notes.md`` §5.1 and §5, with the sources named there): spots
12 in apart centre to centre on a 36 in triangle, the head pin at the lane's length (60 ft) on
the lane's centre line (board 20), rows 12 sin 60° = 10.392 in apart, so the back row is
31 3/16 in behind the head pin; the 7 and 10 spots 18 in from the centre line, 2.75 in from the
edges of a 41.5 in lane. The deck ends 3 in behind the back row (the tail plank). Spots are
2 1/4 in across and a pin's base 2.03 in, so a pinsetter can set a pin up to 0.11 in off its
spot's centre (:data:`SPOT_PLAY_M`).

Around the deck, bowlrec's own approximate shapes (not from a specification): flat gutters
9.25 in wide and 1.875 in deep beside the deck, kickbacks (the side walls) 3 ft high at the
gutters' outer edges from 3 ft before the head pin to the pit, and the pit, a floor 10 in below
the deck behind the tail plank with the rear cushion 33 in behind it (USBC's string-pinsetter
minimum for the ball stop cushion).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bowlrec.units import IN_M

from .profile import CG_RANGE_M, MASS_RANGE_KG, mass_properties

__all__ = [
    "PIN_ROWS",
    "SPOT_PLAY_M",
    "Deck",
    "PinSet",
    "set_pins",
    "spot_offsets_m",
]

#: pins per row, front to back, each row left to right as the bowler sees it (+y first)
PIN_ROWS: tuple[tuple[int, ...], ...] = ((1,), (2, 3), (4, 5, 6), (7, 8, 9, 10))
SPOT_SPACING_M = 12.0 * IN_M
ROW_SPACING_M = SPOT_SPACING_M * math.sin(math.pi / 3.0)
#: how far a pin's base centre may stand off its spot's centre (m): (2.25 - 2.03) / 2 in
SPOT_PLAY_M = (2.25 - 2.03) / 2.0 * IN_M
TAIL_PLANK_M = 3.0 * IN_M
GUTTER_WIDTH_M = 9.25 * IN_M
GUTTER_DEPTH_M = 1.875 * IN_M
KICKBACK_HEIGHT_M = 36.0 * IN_M
KICKBACK_START_M = 36.0 * IN_M
PIT_DEPTH_M = 10.0 * IN_M
CUSHION_M = 33.0 * IN_M


def spot_offsets_m() -> dict[int, tuple[float, float]]:
    """Each pin's spot relative to the head pin's spot (dx, dy) in metres (+dy: left)."""
    out: dict[int, tuple[float, float]] = {}
    for row, pins in enumerate(PIN_ROWS):
        for k, pin in enumerate(pins):
            dy = (len(pins) - 1) / 2.0 * SPOT_SPACING_M - k * SPOT_SPACING_M
            out[pin] = (row * ROW_SPACING_M, dy)
    return out


@dataclass(frozen=True)
class Deck:
    """Where the deck is on a lane of the given length and width (m)."""

    lane_length_m: float
    lane_width_m: float

    @property
    def head_pin_xy_m(self) -> tuple[float, float]:
        return self.lane_length_m, self.lane_width_m / 2.0

    @property
    def end_x_m(self) -> float:
        """x of the deck's end, the tail plank's back edge (m)."""
        return self.lane_length_m + 3.0 * ROW_SPACING_M + TAIL_PLANK_M

    def spot_m(self, pin: int) -> tuple[float, float]:
        """The lane-frame (x, y) of ``pin``'s spot (m)."""
        dx, dy = spot_offsets_m()[pin]
        x0, y0 = self.head_pin_xy_m
        return x0 + dx, y0 + dy

    def on_deck(self, x_m: float, y_m: float) -> bool:
        """True when (x, y) is over the deck (between the lane's edges, before the tail
        plank's back edge)."""
        return 0.0 <= y_m <= self.lane_width_m and x_m <= self.end_x_m


@dataclass(frozen=True)
class PinSet:
    """The pins as set for one ball: which stand, where (lane-frame base centre, m), their mass
    (kg) and centre-of-gravity height (m)."""

    pins: tuple[int, ...]
    base_xy_m: dict[int, tuple[float, float]]
    mass_kg: dict[int, float]
    cg_height_m: dict[int, float]
    seed: int | None = None
    extras: dict[str, float] = field(default_factory=dict)

    def positions(self) -> NDArray[np.float64]:
        """(len(pins), 2) base centres in pin order."""
        return np.array([self.base_xy_m[p] for p in self.pins], dtype=np.float64)


def set_pins(
    deck: Deck,
    pins: tuple[int, ...] = tuple(range(1, 11)),
    *,
    seed: int | None = None,
    at: dict[int, tuple[float, float]] | None = None,
) -> PinSet:
    """The pins ``pins`` set on ``deck``: on their spots' centres with the nominal mass (3 lb
    8 oz) and the profile's centre of gravity when ``seed`` is None; with a seed, each pin's
    mass uniform in USBC's 3 lb 6 oz - 3 lb 10 oz, its centre of gravity uniform in 5 40/64 -
    5 60/64 in and its base uniform over the disc of :data:`SPOT_PLAY_M` around its spot
    (``numpy.random.default_rng(seed)``). ``at`` places given pins at given base centres
    instead (a pin left standing off its spot)."""
    nominal = mass_properties()
    base: dict[int, tuple[float, float]] = {}
    mass: dict[int, float] = {}
    cg: dict[int, float] = {}
    rng = None if seed is None else np.random.default_rng(seed)
    for pin in pins:
        x, y = deck.spot_m(pin)
        if rng is None:
            mass[pin], cg[pin] = nominal.mass_kg, nominal.cg_height_m
        else:
            mass[pin] = float(rng.uniform(*MASS_RANGE_KG))
            cg[pin] = float(rng.uniform(*CG_RANGE_M))
            r = SPOT_PLAY_M * math.sqrt(float(rng.uniform()))
            a = 2.0 * math.pi * float(rng.uniform())
            x, y = x + r * math.cos(a), y + r * math.sin(a)
        if at is not None and pin in at:
            x, y = at[pin]
        base[pin] = (x, y)
    return PinSet(tuple(pins), base, mass, cg, seed)
