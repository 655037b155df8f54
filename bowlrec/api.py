"""The one-call entry point: a scene (object, dict or file) in, a Trajectory out."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .core.plan import Plan
from .core.trajectory import Trajectory
from .sinks.outcome import described
from .spec import Scene, load_scene


def as_scene(scene: Scene | dict[str, Any] | str | Path) -> Scene:
    """Validate a scene given as a Scene, a mapping, or a path to a .json/.yaml file."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return Scene.model_validate(scene)
    return load_scene(scene)


def simulate(scene: Scene | dict[str, Any] | str | Path) -> Trajectory:
    """Simulate one delivery from release to its outcome; see :class:`Trajectory`."""
    return run_plan(as_scene(scene).resolve())


def run_plan(
    plan: Plan, method: str = "auto", stations_m: Sequence[float] = (), turns: bool = False
) -> Trajectory:
    """Simulate a resolved scene (:func:`bowlrec.core.solver.solve`, ``method``, observed
    ``stations_m`` and ``turns`` as there) and tell its outcome in words (the summary's
    ``message``)."""
    from .core.solver import solve

    return described(solve(plan, method, stations_m, turns), plan)
