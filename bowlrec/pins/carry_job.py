"""A carry-map job file (format ``bowlrec-carry``): the grid of entries at the pins, the repeats
and the pin model, as ``bowlrec carry`` runs it.

::

    format: bowlrec-carry
    name: usbc-window
    boards: {from: 15.0, to: 22.0, step: 0.5}   # or a list; board at the head pin's line
    angles_deg: {from: 1.0, to: 10.0, step: 1.0}
    speeds_mph: [16.0]                          # at the pins
    axis_tilts_deg: [10.0]
    repeats: 20                                 # racks per cell, seeds first_seed + r
    first_seed: 0
    hand: right
    ball: {weight_lb: 15.0, rg_in: 2.5}
    deck_friction: 0.25                         # the lane's friction under the ball there
    pins: {pin_pin_friction: 0.12}              # the pin model's parameters (default: its own)

Boards are counted from the bowler's own gutter; angles are toward the head pin. Each entry is
a ball arriving rolling (:mod:`bowlrec.pins.entry`), each repeat a rack whose pins' weights,
centres of gravity and spotting are drawn within USBC's tolerances from its seed
(:mod:`bowlrec.pins.carry`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from bowlrec.errors import JobError, SpecFileError
from bowlrec.file_kinds import wrong_kind
from bowlrec.spec._base import SpecModel, spec_error
from bowlrec.spec.errors import format_validation_error
from bowlrec.spec.loading import read_mapping
from bowlrec.spec.pins import PinOptions

from .entry import PinEntry

__all__ = ["CARRY_FORMAT", "MAX_DELIVERIES", "CarryBall", "CarryJob", "Steps", "load_carry_job"]

CARRY_FORMAT = "bowlrec-carry"
#: the most deliveries (cells x repeats) one job may ask for
MAX_DELIVERIES = 200_000


class Steps(SpecModel):
    """Values from ``from`` to ``to`` (both included when on the step) every ``step``."""

    start: float = Field(alias="from", allow_inf_nan=False)
    stop: float = Field(alias="to", allow_inf_nan=False)
    step: float = Field(gt=0.0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _ordered(self) -> Steps:
        if self.stop < self.start:
            raise spec_error(f"to = {self.stop:g} must not be below from = {self.start:g}")
        if (self.stop - self.start) / self.step > 1000:
            raise spec_error("from/to/step give more than 1000 values")
        return self

    def values(self) -> tuple[float, ...]:
        n = int(math.floor((self.stop - self.start) / self.step + 1e-9)) + 1
        return tuple(round(self.start + k * self.step, 10) for k in range(n))


class CarryBall(SpecModel):
    """The ball: weight (lb, 6-16) and radius of gyration (in, 2.43-2.80; USBC's range)."""

    weight_lb: float = Field(default=15.0, ge=6.0, le=16.0, allow_inf_nan=False)
    rg_in: float = Field(default=2.5, ge=2.43, le=2.8, allow_inf_nan=False)


def _axis(lo: float, hi: float, what: str) -> Any:
    return Field(
        description=f"{what}: a list or {{from, to, step}}; each in [{lo:g}, {hi:g}].",
    )


class CarryJob(SpecModel):
    """A carry map to run (module docstring)."""

    format: Literal["bowlrec-carry"] = Field(default="bowlrec-carry")
    name: str = Field(default="carry-map", min_length=1, max_length=80)
    description: str = Field(default="")
    boards: list[float] | Steps = _axis(1.0, 39.0, "Entry boards at the head pin's line")
    angles_deg: list[float] | Steps = _axis(-5.0, 15.0, "Entry angles toward the head pin (deg)")
    speeds_mph: list[float] | Steps = Field(default_factory=lambda: [16.0])
    axis_tilts_deg: list[float] | Steps = Field(default_factory=lambda: [10.0])
    repeats: int = Field(default=20, ge=1, le=10_000, description="Racks per cell.")
    first_seed: int = Field(default=0, ge=0, description="Seed of the first rack.")
    hand: Literal["right", "left"] = Field(default="right")
    ball: CarryBall = Field(default_factory=CarryBall)
    deck_friction: float = Field(default=0.25, ge=0.0, le=1.0, allow_inf_nan=False)
    pins: PinOptions = Field(default_factory=PinOptions)

    @field_validator("pins")
    @classmethod
    def _whole_racks(cls, pins: PinOptions) -> PinOptions:
        if pins.seed is not None or len(pins.standing) != 10 or pins.moved:
            raise spec_error(
                "pins.seed, pins.standing and pins.moved are set by the map (full racks, "
                "seeds first_seed + r): leave them out"
            )
        return pins

    def values(self, name: str) -> tuple[float, ...]:
        axis = getattr(self, name)
        return axis.values() if isinstance(axis, Steps) else tuple(float(v) for v in axis)

    @model_validator(mode="after")
    def _ranges(self) -> CarryJob:
        limits = {
            "boards": (1.0, 39.0),
            "angles_deg": (-5.0, 15.0),
            "speeds_mph": (8.0, 30.0),
            "axis_tilts_deg": (0.0, 60.0),
        }
        cells = 1
        for name, (lo, hi) in limits.items():
            values = self.values(name)
            if not values:
                raise spec_error(f"{name} is empty: give at least one value")
            bad = [v for v in values if not lo <= v <= hi]
            if bad:
                raise spec_error(f"{name} = {bad[0]:g} is outside [{lo:g}, {hi:g}]")
            cells *= len(values)
        if cells * self.repeats > MAX_DELIVERIES:
            raise spec_error(
                f"{cells} cells x {self.repeats} repeats = {cells * self.repeats:,} deliveries; "
                f"at most {MAX_DELIVERIES:,} per job"
            )
        return self

    def grid(self) -> Any:
        """The :class:`~bowlrec.pins.carry.CarryGrid` of this job."""
        from .carry import CarryGrid

        base = PinEntry(
            weight_lb=self.ball.weight_lb,
            rg_in=self.ball.rg_in,
            deck_friction=self.deck_friction,
            hand=self.hand,
        )
        return CarryGrid(
            boards=self.values("boards"),
            angles_deg=self.values("angles_deg"),
            speeds_mph=self.values("speeds_mph"),
            axis_tilts_deg=self.values("axis_tilts_deg"),
            repeats=self.repeats,
            first_seed=self.first_seed,
            base=base,
        )

    def pin_plan(self) -> Any:
        """The pin model's :class:`~bowlrec.core.plan.PinPlan` (names the leaves for ``hand``)."""
        from bowlrec.spec.resolve import pin_plan

        return pin_plan(self.pins.model_copy(update={"hand": self.hand}))


def load_carry_job(path: str | Path) -> CarryJob:
    """The carry job in a JSON or YAML file; JobError with one line per problem, each starting
    with the path (a missing or unreadable file too)."""
    try:
        data = read_mapping(path)
        other = wrong_kind(data, "bowlrec-carry")
        if other is not None:
            raise JobError(f"{path}: {other}")
        return CarryJob.model_validate(data)
    except ValidationError as err:
        lines = format_validation_error(err).splitlines()
        raise JobError("\n".join(f"{path}: {line}" for line in lines)) from None
    except (SpecFileError, OSError) as err:
        reason = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
        raise JobError(f"{path}: {reason}") from None
