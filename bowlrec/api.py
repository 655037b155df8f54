"""The front door: a scene (object, mapping or file) in, a Trajectory out, or stored in an
archive."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .core.trajectory import Trajectory
from .scene_input import SceneSource, parse_scene_input

if TYPE_CHECKING:
    from .archive import AddResult, Archive
    from .archive.group_commit import GroupCommitter
    from .core.plan import Plan
    from .spec import Scene


def as_scene(scene: SceneSource) -> Scene:
    """The validated physical scene of a :class:`~bowlrec.spec.Scene` (returned as it is), a
    :class:`~bowlrec.bowling.scene.BowlerScene`, a mapping (physical, or bowler-language with
    ``"format": "bowler"``) or a path to a .json/.yaml/.yml file: the one way in,
    :func:`bowlrec.scene_input.parse_scene_input`. Raises
    :class:`~bowlrec.errors.SceneInputError` (a ``ValueError``) naming each bad field, and the
    file for a file."""
    return parse_scene_input(scene).scene


def simulate(scene: SceneSource) -> Trajectory:
    """Simulate one delivery from release to its outcome; see :class:`Trajectory`. ``scene``
    as :func:`as_scene` takes it (SceneInputError when it is invalid). With ``options.pins``
    the trajectory's ``pins`` holds what the pins did (:func:`with_pins`)."""
    from .core.solver import run_plan

    plan = as_scene(scene).resolve()
    return with_pins(plan, run_plan(plan))


def with_pins(plan: Plan, trajectory: Trajectory) -> Trajectory:
    """``trajectory`` with its pins (:func:`bowlrec.pins.outcome.pin_outcome`) when ``plan``
    asks for pin action, else as it is. MissingExtraError without the ``pins`` extra."""
    if plan.pins is None:  # without importing the pin engine
        return trajectory
    from .pins.outcome import with_pins as pinned

    return pinned(plan, trajectory)


def simulate_into(
    archive: Archive,
    scene: SceneSource,
    *,
    ball_ref: str | None = None,
    method: str = "auto",
    group: GroupCommitter | None = None,
) -> AddResult:
    """Simulate ``scene`` (as :func:`as_scene` takes it) and store it in ``archive``, unless its
    run ID is archived already (then the stored trajectory is returned and nothing is
    simulated or written). A stored copy found damaged is set aside and the scene simulated
    again. ``ball_ref`` ("name@version")
    names the library ball the scene used (None: looked up by spec); ``method`` as in
    :func:`bowlrec.core.solver.solve`; ``group``: a
    :class:`~bowlrec.archive.group_commit.GroupCommitter` that seals summary-only runs together
    with those of other threads (a server's concurrent requests)."""
    import time

    from .archive import AddResult, run_id
    from .core.solver import run_plan, use_closed_form
    from .errors import RunDamagedError
    from .sinks.common import RunData

    scene = as_scene(scene)
    plan = scene.resolve()
    rid = run_id(plan)
    found = archive.locate(rid)
    if found is not None:
        try:
            return AddResult(rid, found[2], False, archive.load(rid).trajectory)
        except RunDamagedError as err:
            archive.set_aside(rid, found[0], f"damaged: {err.reason}")
    start = time.perf_counter()
    traj = with_pins(plan, run_plan(plan, method))
    wall = time.perf_counter() - start
    used = (
        method if method != "auto" else ("closed_form" if use_closed_form(plan) else "integrator")
    )
    run = RunData(scene, plan, traj, rid)
    if group is not None and traj.n_samples == 0:
        record = archive.record(run, wall_time_s=wall, ball_ref=ball_ref, solver=used)
        added, path = group.add(record)
        return AddResult(rid, path, added, traj)
    return archive.add(run, wall_time_s=wall, ball_ref=ball_ref, solver=used)
