"""Carry maps: strike probability and leaves over entry board x entry angle (x speed x axis
tilt), each entry thrown at many racks whose pins' tolerances are drawn from their own seeds.

A :class:`CarryGrid` names the entries (:class:`~bowlrec.pins.entry.PinEntry` values: board and
angle at the head pin's line, speed at the pins in mph, axis tilt in degrees; the rest of the
ball, the hand and the lane from ``base``) and the repeats: repeat ``r`` sets the pins with
``set_pins(deck, seed=first_seed + r)`` (weight, centre of gravity and spotting within USBC's
tolerances), the same racks for every cell, so cells differ by their entry only (common random
numbers: differences between neighbouring cells are less noisy than the cells themselves).

:func:`simulate_shots` runs any list of (entry, seed) shots, in process (``workers=1``) or on a
process pool (``concurrent.futures.ProcessPoolExecutor``, chunks of shots per task); every shot
is a pure function of its entry, its seed and the pin model, and results come back in the
shots' order, so a map is the same whatever the number of workers (MuJoCo is deterministic on
one build). :func:`carry_map` runs a grid and sums each cell (:class:`CarryCell`): strikes with
the binomial standard error sqrt(p (1 - p) / n), the leaves counted by the set of standing pins
(named as bowlers name them by :func:`bowlrec.pins.leaves.name_leave`, first ball, the entry's
hand), the mean pinfall, how often the ball touched each pin and the mean exit board.

Conventions: boards from the bowler's own gutter, fractional (a right-hander's pocket is 17.5);
angles positive toward the head pin; pins numbered as a right-hander sees them (pin 3 right of
the head pin) for both hands; exit board: where the ball's centre crossed the deck's end, in
boards from the bowler's own gutter.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.units import BOARDS, FT_M, IN_M

from .entry import PinEntry, entry_state
from .leaves import name_leave

if TYPE_CHECKING:
    from bowlrec.core.plan import PinPlan

__all__ = [
    "CarryCell",
    "CarryGrid",
    "CarryMap",
    "Shot",
    "carry_map",
    "default_plan",
    "run_shot",
    "simulate_shots",
]


def default_plan() -> PinPlan:
    """The pin model with its default (calibrated) parameters."""
    from bowlrec.spec.pins import PinOptions
    from bowlrec.spec.resolve import pin_plan

    plan = pin_plan(PinOptions())
    assert plan is not None
    return plan


@dataclass(frozen=True)
class Shot:
    """One entry thrown at one rack: the rack's seed (None: nominal pins on their spots), the
    pins standing at rest, those the ball touched (in order), the exit board (None if the ball
    did not reach the deck's end), whether everything came to rest before the engine's
    ``max_time_s`` and the engine's wall time (s; not part of the result's identity)."""

    seed: int | None
    standing: tuple[int, ...]
    touched: tuple[int, ...]
    exit_board: float | None
    at_rest: bool
    wall_s: float = field(default=0.0, compare=False)

    @property
    def strike(self) -> bool:
        return not self.standing

    @property
    def pinfall(self) -> int:
        return 10 - len(self.standing)


def _exit_board(exit_y_m: float | None, entry: PinEntry) -> float | None:
    if exit_y_m is None:
        return None
    width = entry.lane_width_in * IN_M
    d = exit_y_m if entry.hand == "right" else width - exit_y_m
    return d / (width / BOARDS) + 0.5


def run_shot(entry: PinEntry, seed: int | None, pins: PinPlan) -> Shot:
    """``entry`` thrown at the rack of ``seed`` (None: nominal pins) with the pin model ``pins``."""
    from .deck import Deck, set_pins
    from .engine import simulate_pins

    deck = Deck(entry.lane_length_ft * FT_M, entry.lane_width_in * IN_M)
    action = simulate_pins(entry_state(entry), pins, deck, set_pins(deck, seed=seed))
    return Shot(
        seed=seed,
        standing=action.standing,
        touched=action.touched,
        exit_board=_exit_board(action.exit_y_m, entry),
        at_rest=action.at_rest,
        wall_s=action.wall_time_s,
    )


def _run_chunk(chunk: tuple[tuple[tuple[PinEntry, int | None], ...], PinPlan]) -> list[Shot]:
    shots, pins = chunk
    return [run_shot(entry, seed, pins) for entry, seed in shots]


def _chunks(
    shots: Sequence[tuple[PinEntry, int | None]], size: int
) -> Iterator[tuple[tuple[PinEntry, int | None], ...]]:
    for k in range(0, len(shots), size):
        yield tuple(shots[k : k + size])


def simulate_shots(
    shots: Sequence[tuple[PinEntry, int | None]],
    pins: PinPlan | None = None,
    *,
    workers: int | None = None,
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[Shot]:
    """Each (entry, seed) of ``shots`` through the pins of the model ``pins`` (default:
    :func:`default_plan`), in the shots' order. ``workers``: processes (None: the CPU count;
    1: in this process, no pool); ``chunk``: shots per pool task (None: about four tasks per
    worker, at most 16 shots); ``progress(done, total)`` after each chunk."""
    plan = default_plan() if pins is None else pins
    count = (os.cpu_count() or 1) if workers is None else workers
    if count < 1:
        raise ValueError(f"workers = {workers} must be at least 1")
    total = len(shots)
    size = chunk or max(1, min(16, math.ceil(total / (4 * count))))
    tasks = [(c, plan) for c in _chunks(shots, size)]
    out: list[Shot] = []
    if count == 1 or len(tasks) <= 1:
        for task in tasks:
            out.extend(_run_chunk(task))
            if progress is not None:
                progress(len(out), total)
        return out
    with ProcessPoolExecutor(max_workers=min(count, len(tasks))) as pool:
        for part in pool.map(_run_chunk, tasks):
            out.extend(part)
            if progress is not None:
                progress(len(out), total)
    return out


@dataclass(frozen=True)
class CarryGrid:
    """The entries of a carry map and its repeats.

    boards (board from the bowler's gutter), angles_deg, speeds_mph (at the pins) and
    axis_tilts_deg span the grid; ``base`` gives the rest of each entry (weight, radius of
    gyration, the deck's friction under the ball, the hand, the lane); repeat r of every cell
    sets the pins with seed ``first_seed + r``.
    """

    boards: tuple[float, ...]
    angles_deg: tuple[float, ...]
    speeds_mph: tuple[float, ...] = (PinEntry.speed_mph,)
    axis_tilts_deg: tuple[float, ...] = (PinEntry.axis_tilt_deg,)
    repeats: int = 20
    first_seed: int = 0
    base: PinEntry = PinEntry()

    def __post_init__(self) -> None:
        for name in ("boards", "angles_deg", "speeds_mph", "axis_tilts_deg"):
            if not getattr(self, name):
                raise ValueError(f"{name} is empty: a carry map needs at least one value")
        if self.repeats < 1:
            raise ValueError(f"repeats = {self.repeats} must be at least 1")

    @property
    def seeds(self) -> tuple[int, ...]:
        return tuple(self.first_seed + r for r in range(self.repeats))

    def entries(self) -> list[PinEntry]:
        """The cells' entries, boards fastest, then angles, speeds, tilts."""
        return [
            dataclasses.replace(self.base, board=b, angle_deg=a, speed_mph=s, axis_tilt_deg=t)
            for t in self.axis_tilts_deg
            for s in self.speeds_mph
            for a in self.angles_deg
            for b in self.boards
        ]

    @property
    def size(self) -> int:
        """Deliveries in the map: cells x repeats."""
        return len(self.entries()) * self.repeats


@dataclass(frozen=True)
class CarryCell:
    """One entry's repeats and what they add up to."""

    entry: PinEntry
    shots: tuple[Shot, ...]

    @property
    def n(self) -> int:
        return len(self.shots)

    @property
    def strikes(self) -> int:
        return sum(s.strike for s in self.shots)

    @property
    def strike_probability(self) -> float:
        return self.strikes / self.n

    @property
    def strike_se(self) -> float:
        """The binomial standard error of :attr:`strike_probability`, sqrt(p (1 - p) / n)."""
        p = self.strike_probability
        return math.sqrt(p * (1.0 - p) / self.n)

    @property
    def leaves(self) -> dict[tuple[int, ...], int]:
        """How many repeats left each set of standing pins (() is a strike), most first."""
        counts = Counter(s.standing for s in self.shots)
        return dict(sorted(counts.items(), key=lambda kv: (-kv[1], len(kv[0]), kv[0])))

    @property
    def leave_names(self) -> dict[str, int]:
        """:attr:`leaves` by the leaves' names (first ball, the entry's hand)."""
        out: Counter[str] = Counter()
        for standing, k in self.leaves.items():
            out[name_leave(standing, hand=self.entry.hand, first_ball=True)] += k
        return dict(out.most_common())

    @property
    def mean_pinfall(self) -> float:
        return sum(s.pinfall for s in self.shots) / self.n

    @property
    def touched_frequency(self) -> dict[int, float]:
        """Pin -> the share of repeats in which the ball touched it (pins 1-10)."""
        return {p: sum(p in s.touched for s in self.shots) / self.n for p in range(1, 11)}

    def standing_frequency(self, pin: int) -> float:
        """The share of repeats that left ``pin`` standing."""
        return sum(pin in s.standing for s in self.shots) / self.n

    @property
    def mean_exit_board(self) -> float | None:
        """The mean exit board over the repeats whose ball reached the deck's end (None if
        none did)."""
        boards = [s.exit_board for s in self.shots if s.exit_board is not None]
        return sum(boards) / len(boards) if boards else None

    def to_dict(self) -> dict[str, Any]:
        e = self.entry
        return {
            "board": e.board,
            "angle_deg": e.angle_deg,
            "speed_mph": e.speed_mph,
            "axis_tilt_deg": e.axis_tilt_deg,
            "n": self.n,
            "strikes": self.strikes,
            "strike_probability": self.strike_probability,
            "strike_se": self.strike_se,
            "leaves": {name: k for name, k in self.leave_names.items()},
            "mean_pinfall": self.mean_pinfall,
            "touched_frequency": {str(p): f for p, f in self.touched_frequency.items()},
            "mean_exit_board": self.mean_exit_board,
        }


@dataclass(frozen=True)
class CarryMap:
    """A grid's cells (in :meth:`CarryGrid.entries`'s order), the workers that ran it and its
    wall time (s)."""

    grid: CarryGrid
    cells: tuple[CarryCell, ...]
    workers: int
    wall_time_s: float

    def cell(
        self,
        board: float,
        angle_deg: float,
        speed_mph: float | None = None,
        axis_tilt_deg: float | None = None,
    ) -> CarryCell:
        """The cell of this entry (speed and tilt: the grid's first when None); KeyError if the
        grid has no such cell."""
        s = self.grid.speeds_mph[0] if speed_mph is None else speed_mph
        t = self.grid.axis_tilts_deg[0] if axis_tilt_deg is None else axis_tilt_deg
        for c in self.cells:
            e = c.entry
            if (e.board, e.angle_deg, e.speed_mph, e.axis_tilt_deg) == (board, angle_deg, s, t):
                return c
        raise KeyError(f"no cell at board {board}, {angle_deg} deg, {s} mph, tilt {t} deg")

    def strike_grid(
        self, speed_mph: float | None = None, axis_tilt_deg: float | None = None
    ) -> NDArray[np.float64]:
        """Strike probability as an (angles, boards) array at one speed and tilt (the grid's
        first when None)."""
        g = self.grid
        return np.array(
            [
                [self.cell(b, a, speed_mph, axis_tilt_deg).strike_probability for b in g.boards]
                for a in g.angles_deg
            ]
        )

    def to_dict(self) -> dict[str, Any]:
        g = self.grid
        return {
            "boards": list(g.boards),
            "angles_deg": list(g.angles_deg),
            "speeds_mph": list(g.speeds_mph),
            "axis_tilts_deg": list(g.axis_tilts_deg),
            "repeats": g.repeats,
            "first_seed": g.first_seed,
            "hand": g.base.hand,
            "deliveries": g.size,
            "workers": self.workers,
            "wall_time_s": self.wall_time_s,
            "cells": [c.to_dict() for c in self.cells],
        }


def carry_map(
    grid: CarryGrid,
    pins: PinPlan | None = None,
    *,
    workers: int | None = None,
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CarryMap:
    """The carry map of ``grid`` with the pin model ``pins`` (default: :func:`default_plan`);
    ``workers``, ``chunk`` and ``progress`` as :func:`simulate_shots` takes them."""
    start = time.perf_counter()
    entries = grid.entries()
    shots = [(e, s) for e in entries for s in grid.seeds]
    done = simulate_shots(shots, pins, workers=workers, chunk=chunk, progress=progress)
    r = grid.repeats
    cells = tuple(
        CarryCell(entry=e, shots=tuple(done[k * r : (k + 1) * r])) for k, e in enumerate(entries)
    )
    count = (os.cpu_count() or 1) if workers is None else workers
    return CarryMap(grid, cells, count, time.perf_counter() - start)
