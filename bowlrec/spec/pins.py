"""Pin action asked for in a scene (``options.pins``): the pin model's parameters.

Restitution and friction are dimensionless; times in seconds. The defaults are the calibrated
values of ``docs/pins.md`` (``python -m benchmarks.pins --calibrate``): no measurement of pin
restitution or friction is published, so they are fitted to published carry facts and the
page says which facts they were fitted to and which were held out.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from ._base import SpecModel, fmt, spec_error

__all__ = ["DEFAULT_PIN_CONTACTS", "PinOptions"]

#: the pin model's contact parameters: (restitution, friction) per pair of surfaces; fitted
#: (pin-pin, ball-pin friction, pin-deck friction) in bowlrec/pins/data/pin_contacts_fit.json
DEFAULT_PIN_CONTACTS: dict[str, tuple[float, float]] = {
    "ball_pin": (0.578, 0.1),
    "pin_pin": (0.6, 0.06),
    "pin_deck": (0.083, 0.15),
    "pin_kickback": (0.5, 0.2),
}
_E_RANGE = (0.001, 0.95)
_MU_MAX = 2.0


def _restitution(pair: str, what: str) -> float:
    return Field(
        default=DEFAULT_PIN_CONTACTS[pair][0],
        ge=_E_RANGE[0],
        le=_E_RANGE[1],
        allow_inf_nan=False,
        description=f"Restitution of {what} (normal speed after / before), in "
        f"[{_E_RANGE[0]:g}, {_E_RANGE[1]:g}].",
    )


def _friction(pair: str, what: str) -> float:
    return Field(
        default=DEFAULT_PIN_CONTACTS[pair][1],
        ge=0.0,
        le=_MU_MAX,
        allow_inf_nan=False,
        description=f"Coulomb friction coefficient of {what}, in [0, {_MU_MAX:g}].",
    )


class PinOptions(SpecModel):
    """The pins after the lane: the contact model per pair of surfaces, the pins' tolerances
    and the engine's settings (MuJoCo, the ``bowlrec[pins]`` extra)."""

    ball_pin_restitution: float = _restitution("ball_pin", "the ball on a pin")
    ball_pin_friction: float = _friction("ball_pin", "the ball on a pin")
    pin_pin_restitution: float = _restitution("pin_pin", "a pin on a pin")
    pin_pin_friction: float = _friction("pin_pin", "a pin on a pin")
    pin_deck_restitution: float = _restitution("pin_deck", "a pin on the deck and in the gutters")
    pin_deck_friction: float = _friction("pin_deck", "a pin on the deck and in the gutters")
    pin_kickback_restitution: float = _restitution("pin_kickback", "a pin on a kickback")
    pin_kickback_friction: float = _friction("pin_kickback", "a pin on a kickback")
    seed: int | None = Field(
        default=None,
        ge=0,
        description=(
            "None: nominal pins on their spots' centres. An integer draws each pin's weight, "
            "centre of gravity and spotting within USBC's tolerances from this seed."
        ),
    )
    standing: list[int] = Field(
        default_factory=lambda: list(range(1, 11)),
        description="The pins set before the ball (pin numbers 1-10, as a right-hander sees "
        "them: 2 left of the head pin).",
    )
    moved: dict[int, tuple[float, float]] = Field(
        default_factory=dict,
        description=(
            "Standing pins off their spots: pin number -> (dx, dy), its base centre's offset "
            "from its spot's centre (m, lane frame: +x toward the pit, +y left), each within "
            "0.3 m; the pins a previous ball moved, as a pinsetter sets them back."
        ),
    )
    hand: Literal["auto", "right", "left"] = Field(
        default="auto",
        description=(
            "Whose names the leave gets (a right-hander's stone 9 is a left-hander's 8); "
            "auto: a ball moving left at the pins is a right-hander's."
        ),
    )
    timestep_s: float = Field(
        default=2e-4,
        ge=2e-5,
        le=5e-4,
        allow_inf_nan=False,
        description="The pin engine's time step (s), in [2e-5, 5e-4].",
    )
    contact_timeconst_s: float = Field(
        default=2e-3,
        ge=4e-5,
        le=2e-2,
        allow_inf_nan=False,
        description=(
            "Time constant of the soft contacts (s), in [4e-5, 0.02] and at least twice timestep_s."
        ),
    )
    max_time_s: float = Field(
        default=4.0,
        gt=0.0,
        le=20.0,
        allow_inf_nan=False,
        description="Pin action stops here at the latest (s after the hand-off), in (0, 20].",
    )
    record_dt_s: float = Field(
        default=0.005,
        ge=1e-3,
        le=0.1,
        allow_inf_nan=False,
        description="Sampling interval of the pins' recorded motion (s), in [0.001, 0.1].",
    )

    @field_validator("standing")
    @classmethod
    def _pins(cls, value: list[int]) -> list[int]:
        if not value:
            raise spec_error(
                "no pin stands: name 1 to 10 pins (1-10), or set options.pins to false for no "
                "pin action"
            )
        bad = [p for p in value if not 1 <= p <= 10]
        if bad:
            raise spec_error(f"pin {bad[0]} is not a pin number: pins are 1-10")
        if len(set(value)) != len(value):
            raise spec_error(f"pins {value} name a pin twice")
        return sorted(value)

    @field_validator("moved")
    @classmethod
    def _moved(cls, value: dict[int, tuple[float, float]]) -> dict[int, tuple[float, float]]:
        for pin, (dx, dy) in value.items():
            if not 1 <= pin <= 10:
                raise spec_error(f"pin {pin} is not a pin number: pins are 1-10")
            if not (abs(dx) <= 0.3 and abs(dy) <= 0.3):
                raise spec_error(
                    f"pin {pin} moved ({fmt(dx)}, {fmt(dy)}) m: each offset must be within 0.3 m"
                )
        return dict(sorted(value.items()))

    @model_validator(mode="after")
    def _timeconst(self) -> PinOptions:
        stray = sorted(set(self.moved) - set(self.standing))
        if stray:
            raise spec_error(
                f"moved names pin {stray[0]}, which is not in standing {self.standing}"
            )
        if self.contact_timeconst_s < 2.0 * self.timestep_s:
            raise spec_error(
                f"contact_timeconst_s = {fmt(self.contact_timeconst_s)} s must be at least "
                f"twice timestep_s = {fmt(self.timestep_s)} s"
            )
        return self
