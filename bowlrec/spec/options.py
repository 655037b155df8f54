"""How to simulate and what to record (s, m/s, m/s^2; rtol dimensionless)."""

from __future__ import annotations

from typing import Literal

from pydantic import (
    Field,
    SerializationInfo,
    SerializerFunctionWrapHandler,
    model_serializer,
    model_validator,
)

from ._base import PositiveFloat, SpecModel, fmt, spec_error
from .limits import MAX_G_MPS2, MAX_SAMPLES_PER_RUN, MAX_SPEED_MPS, MAX_TIME_S
from .pins import PinOptions

__all__ = ["Options"]


class Options(SpecModel):
    """Integrator, recording and termination settings."""

    rtol: float = Field(
        default=1e-9,
        ge=1e-14,
        le=1e-3,
        allow_inf_nan=False,
        description="Relative tolerance of the integrator, in [1e-14, 1e-3].",
    )
    record: Literal["steps", "rate", "summary"] = Field(
        default="steps",
        description=(
            "steps: a sample per accepted step; rate: samples every record_dt_s; "
            "summary: events and summary only."
        ),
    )
    record_dt_s: PositiveFloat = Field(
        default=0.001,
        description=(
            "Sampling interval when record == 'rate' (s); max_time_s / record_dt_s may not "
            f"exceed {MAX_SAMPLES_PER_RUN:,} samples per run."
        ),
    )
    record_terms: bool = Field(
        default=False, description="Record the per-term torques of every sample."
    )
    slide_to_roll: Literal["exact", "threshold"] = Field(
        default="exact",
        description=(
            "exact: rolling starts where the slip is zero; threshold: the paper's rule, once "
            "|slip| < slip_threshold_mps."
        ),
    )
    slip_threshold_mps: PositiveFloat = Field(
        default=0.01,
        le=MAX_SPEED_MPS,
        description=(
            "Slip speed for slide_to_roll == 'threshold' (m/s), in (0, "
            f"{MAX_SPEED_MPS:g}]; the paper's 1 cm/s."
        ),
    )
    max_time_s: PositiveFloat = Field(
        default=60.0,
        le=MAX_TIME_S,
        description=f"Hard limit on simulated time (s), in (0, {MAX_TIME_S:g}].",
    )
    g_mps2: PositiveFloat = Field(
        default=9.81,
        le=MAX_G_MPS2,
        description=f"Gravitational acceleration (m/s^2), in (0, {MAX_G_MPS2:g}].",
    )
    pins: bool | PinOptions = Field(
        default=False,
        description=(
            "Pin action after the lane (the bowlrec[pins] extra): true for the pin model's "
            "defaults, or its parameters; false: the run ends at the pins."
        ),
    )

    unit_warnings: bool = Field(
        default=True,
        description=(
            "Warn when a value looks typed in another unit (speed_mps = 17: did you mean 17 "
            "mph?); false silences the warnings for this scene (bowlrec/spec/unit_sense.py)."
        ),
    )

    @model_serializer(mode="wrap")
    def _without_pins_off(
        self, handler: SerializerFunctionWrapHandler, info: SerializationInfo
    ) -> dict[str, object]:
        """The options as stored, without ``pins`` when it is off and without
        ``unit_warnings`` when on: a scene at those defaults dumps (and so hashes, in a
        session's ID) as it did before the fields existed."""
        data: dict[str, object] = handler(self)
        if self.pins is False:
            data.pop("pins", None)
        if self.unit_warnings:
            data.pop("unit_warnings", None)
        return data

    @property
    def pin_options(self) -> PinOptions | None:
        """The pin model's parameters, or None without pin action."""
        if self.pins is True:
            return PinOptions()
        return self.pins or None

    @model_validator(mode="after")
    def _samples_bounded(self) -> Options:
        """A fixed-rate recording holds at most MAX_SAMPLES_PER_RUN samples."""
        if self.record == "rate":
            samples = self.max_time_s / self.record_dt_s
            if samples > MAX_SAMPLES_PER_RUN:
                raise spec_error(
                    f"record_dt_s = {fmt(self.record_dt_s)} s over max_time_s = "
                    f"{fmt(self.max_time_s)} s allows {samples:.3g} samples; at most "
                    f"{MAX_SAMPLES_PER_RUN:,} samples per run: use record_dt_s >= "
                    f"{self.max_time_s / MAX_SAMPLES_PER_RUN:.3g} s or a shorter max_time_s"
                )
        return self
