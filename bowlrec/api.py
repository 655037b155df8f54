"""The one-call entry point: a scene (object, dict or file) in, a Trajectory out."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .core.trajectory import Trajectory
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
    from .core.solver import solve

    return solve(as_scene(scene).resolve())
