"""Archived runs made ready to draw: summary-only runs re-recorded with samples, and the
bowler's report of a run with samples.

Most runs of a large archive are stored summary-only (events and the summary, no samples).
:func:`replay_data` simulates such a run again from its stored scene, recording samples every
``record_dt_s`` seconds from the integrator's dense output, and checks the new summary against
the stored one before handing the samples out (:func:`replay_data` says how exactly).
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import TYPE_CHECKING, Any

from bowlrec.errors import ConflictError, SamplesRequiredError

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Summary
    from bowlrec.sinks.common import RunData
    from bowlrec.spec import Scene

    from .store import Archive

__all__ = [
    "DEFAULT_RECORD_DT_S",
    "bowler_report_of",
    "rerecord_is_exact",
    "replay_data",
    "sampled_scene",
    "simulate_sampled",
]

#: sampling interval (s) of a re-recorded run unless the caller gives another
DEFAULT_RECORD_DT_S = 0.005
#: summary fields that count solver work, not the motion; compared only when exact
_SOLVER_COUNTS = ("n_steps", "n_rhs")


def sampled_scene(scene: Scene, record_dt_s: float = DEFAULT_RECORD_DT_S) -> Scene:
    """``scene`` recording samples every ``record_dt_s`` s (``options.record = "rate"``) if it
    is summary-only; a scene that records samples already is returned as it is."""
    if scene.options.record != "summary":
        return scene
    options = scene.options.model_copy(update={"record": "rate", "record_dt_s": record_dt_s})
    return scene.model_copy(update={"options": options})


def simulate_sampled(scene: Scene, record_dt_s: float = DEFAULT_RECORD_DT_S) -> RunData:
    """Simulate :func:`sampled_scene` (``scene``, ``record_dt_s``) now (not archived): a run
    with samples, without run ID or provenance."""
    from bowlrec.core.solver import run_plan
    from bowlrec.pins.outcome import with_pins
    from bowlrec.sinks.common import RunData

    sampled = sampled_scene(scene, record_dt_s)
    plan = sampled.resolve()
    return RunData(sampled, plan, with_pins(plan, run_plan(plan)))


def rerecord_is_exact(plan: Plan) -> bool:
    """Whether recording samples leaves a summary-only run of ``plan`` bit for bit the same.

    Samples at a rate are read off the dense output of the steps, and the step control does not
    depend on them, so the integrator takes the same steps and the summary is identical (the
    step and right-hand-side counts included) whenever the summary-only run already used the
    integrator with the orientation fully weighted in the error norm: every ball with a
    principal-moment anisotropy or center-of-mass offset of at least ~1e-3 (relative). A
    summary-only run of a uniform ball uses the closed form (or the integrator without the
    quaternion), and a nearly uniform one weights the quaternion's error less
    (:func:`bowlrec.core.arguments.orientation_weight`); recording weighs it fully, so the steps
    and the last bits of the numbers differ.
    """
    from bowlrec.core.arguments import needs_orientation, orientation_weight, use_closed_form

    return not use_closed_form(plan) and needs_orientation(plan) and orientation_weight(plan) == 1.0


def _first_difference(stored: Summary, new: Summary, *, exact: bool, rtol: float) -> str | None:
    """The first summary field where ``new`` disagrees with ``stored`` (see :func:`replay_data`
    for the rule), or None."""
    for f in fields(stored):
        a, b = getattr(stored, f.name), getattr(new, f.name)
        if a == b:
            continue
        if exact:
            return f.name
        if f.name in _SOLVER_COUNTS:
            continue
        if isinstance(a, float) and isinstance(b, float) and abs(a - b) <= rtol * (1 + abs(a)):
            continue
        return f.name
    return None


def _show(value: Any) -> str:
    return f"{value:.6g}" if isinstance(value, float) else repr(value)


def replay_data(
    archive: Archive, run_id: str, *, record_dt_s: float = DEFAULT_RECORD_DT_S
) -> RunData:
    """Run ``run_id`` (an ID or unique prefix) of ``archive`` with samples, for a viewer or a
        figure.

        A run stored with samples is returned as :meth:`Archive.run_data` gives it. A summary-only
        run is simulated again from its stored scene recording samples every ``record_dt_s`` s
        (``options.record = "rate"``); the returned run has that scene and its plan, the stored
        run's ID and provenance, and ``rerecorded_dt_s`` (s) added to the provenance. Nothing is
        written to the archive.

        A run with pin action runs through the pins again too (the engine is deterministic on one
    build), and its standing and touched pins must be the stored ones.

        The new summary is checked against the stored one. When :func:`rerecord_is_exact` holds for
        the stored plan (a real, non-uniform ball), the same steps are taken and every field must be
        equal bit for bit. Otherwise (uniform or nearly uniform balls) the outcome, message and
        event count must be equal, the step counts are not compared, and each float field must
        agree within ``rtol * (1 + |stored|)`` in its own unit (m, deg, s, m/s, rpm), ``rtol``
        being the scene's integrator tolerance: both runs solve the same equations to that
        tolerance, and on the benchmark deliveries (random_scene_dicts, Table III, uniform balls)
        they differ by less than 1e-5 of it. A larger difference means the stored run was made by
        other physics: :class:`~bowlrec.errors.ConflictError` naming the run and the first field
        that differs.

        Raises :class:`~bowlrec.errors.RunNotFoundError` and
        :class:`~bowlrec.errors.RunDamagedError` as :meth:`Archive.load` does.
    """
    from dataclasses import replace

    from bowlrec.core.codes import RECORD_RATE
    from bowlrec.core.solver import run_plan
    from bowlrec.pins.outcome import with_pins
    from bowlrec.sinks.common import RunData

    stored = archive.run_data(archive.resolve_id(run_id))
    if stored.trajectory.n_samples > 0:
        return stored
    if not (math.isfinite(record_dt_s) and record_dt_s > 0.0):
        raise ValueError(f"record_dt_s = {record_dt_s!r} must be a positive number of seconds")
    scene = sampled_scene(stored.scene, record_dt_s)
    plan = replace(stored.plan, record_mode=RECORD_RATE, record_dt_s=float(record_dt_s))
    trajectory = with_pins(plan, run_plan(plan))
    old, new = stored.trajectory.summary, trajectory.summary
    field = _first_difference(
        old, new, exact=rerecord_is_exact(stored.plan), rtol=float(stored.plan.rtol)
    )
    if field is not None:
        raise ConflictError(
            f"run {stored.run_id}: re-recorded {field} {_show(getattr(new, field))} differs "
            f"from the archived {_show(getattr(old, field))} (made by another physics version?)"
        )
    was, now = stored.trajectory.pins, trajectory.pins
    if (
        was is not None
        and now is not None
        and (was.standing, was.touched)
        != (
            now.standing,
            now.touched,
        )
    ):
        raise ConflictError(
            f"run {stored.run_id}: re-recorded pins leave {now.standing} (touched {now.touched}) "
            f"where the archived run left {was.standing} (touched {was.touched}): made by "
            "another build of the pin engine?"
        )
    provenance = dict(stored.provenance or {})
    provenance["rerecorded_dt_s"] = float(record_dt_s)
    return RunData(scene, plan, trajectory, stored.run_id, provenance)


def bowler_report_of(run: RunData) -> dict[str, Any] | None:
    """The bowler's report (:func:`bowlrec.bowling.report.bowler_report`, as a dict of mph,
    rpm, boards, ft and deg) of ``run`` on a :class:`~bowlrec.bowling.lane.BowlerLane` of the
    scene's lane length and width.

    The handedness is inferred from the hook
    (:func:`~bowlrec.bowling.report.inferred_handedness`): boards are counted from the bowling
    hand's gutter.

    None when the report cannot be made: the run has no samples, or its lane is outside the
    widths and lengths a bowler's lane may have.
    """
    from pydantic import ValidationError

    from bowlrec.bowling.lane import BowlerLane
    from bowlrec.bowling.report import bowler_report, inferred_handedness
    from bowlrec.units import FT_M, IN_M

    if run.trajectory.n_samples == 0:
        return None
    handedness = inferred_handedness(run.trajectory.position_m[:, 1])
    try:
        lane = BowlerLane(
            length_ft=float(run.plan.lane_length_m) / FT_M,
            width_in=float(run.plan.lane_width_m) / IN_M,
        )
        return bowler_report(run.trajectory, lane, handedness).to_dict()
    except (ValidationError, SamplesRequiredError):
        return None
