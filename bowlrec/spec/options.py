"""How to simulate and what to record (s, m/s, m/s^2; rtol dimensionless)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ._base import PositiveFloat, SpecModel

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
        default=0.001, description="Sampling interval when record == 'rate' (s)."
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
        description="Slip speed for slide_to_roll == 'threshold' (m/s); the paper's 1 cm/s.",
    )
    max_time_s: PositiveFloat = Field(default=60.0, description="Hard limit on simulated time (s).")
    g_mps2: PositiveFloat = Field(default=9.81, description="Gravitational acceleration (m/s^2).")
