"""An outcome in words: the one-line message stored with every run's summary.

The core reports how a run ended as a code and numbers (:class:`~bowlrec.core.trajectory.Summary`
without its ``message``); this module tells it, for the command line, the service, the archive
and the batch tables alike.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

__all__ = ["described", "outcome_message"]


def described(trajectory: Trajectory, plan: Plan) -> Trajectory:
    """``trajectory`` with its summary's message set (:func:`outcome_message` under the plan's
    limits); samples and events are shared, not copied."""
    s = trajectory.summary
    message = outcome_message(s.outcome, s.time_s, s.x_end_m, plan.max_time_s, plan.max_steps)
    return trajectory.replaced(summary=replace(s, message=message))


def outcome_message(
    outcome: str, t_end_s: float, x_end_m: float, max_time_s: float, max_steps: int
) -> str:
    """The one-line explanation of an outcome: it ended at time ``t_end_s`` (s) with the center
    at ``x_end_m`` (m), under the run's limits ``max_time_s`` (s) and ``max_steps``."""
    if outcome == "pins":
        return "reached the pins"
    if outcome == "gutter":
        return f"the center crossed a lane edge at x = {x_end_m:.3f} m"
    if outcome == "stopped":
        return f"the ball stopped moving toward the pins at x = {x_end_m:.3f} m"
    if outcome == "airborne":
        if t_end_s == 0.0:
            return (
                "the normal force is not positive at release: the ball would leave the lane "
                "(omega^2 |offset| exceeds g); the model assumes contact"
            )
        return (
            f"the normal force reached zero at t = {t_end_s:.4f} s, x = {x_end_m:.3f} m: the ball "
            "would leave the lane (omega^2 |offset| exceeds g); the model assumes contact"
        )
    if outcome == "max_time":
        return f"no outcome within max_time_s = {max_time_s} s"
    if outcome == "max_steps":
        return f"no outcome within {max_steps} integrator steps"
    if outcome == "stalled":
        return "the integrator stalled (step size underflow or endless phase switching)"
    return outcome
