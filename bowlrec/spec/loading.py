"""Reading and writing scene files (.json, .yaml, .yml)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .scene import Scene

__all__ = ["dump_scene_json", "load_scene", "read_mapping"]

_YAML_SUFFIXES = {".yaml", ".yml"}


def read_mapping(path: str | Path) -> Any:
    """The parsed content of a JSON or YAML file (not validated)."""
    p = Path(path)
    suffix = p.suffix.lower()
    text = p.read_text(encoding="utf-8")
    if suffix == ".json":
        return json.loads(text)
    if suffix in _YAML_SUFFIXES:
        import yaml

        return yaml.safe_load(text)
    raise ValueError(f"{p}: unsupported scene file type {suffix!r} (use .json, .yaml or .yml)")


def load_scene(path: str | Path) -> Scene:
    """Load and validate a scene file; raises ``pydantic.ValidationError`` on invalid content.

    A bowler-language file (top-level ``"format": "bowler"``, see
    :class:`bowlrec.bowling.scene.BowlerScene`) is resolved to the physical scene.
    """
    from bowlrec.scene_input import is_bowler

    data = read_mapping(path)
    if is_bowler(data):
        from bowlrec.bowling.scene import BowlerScene

        return BowlerScene.model_validate(data).to_scene()
    return Scene.model_validate(data)


def dump_scene_json(scene: Scene) -> str:
    """Canonical JSON text of a scene: indent 2, sorted keys, trailing newline."""
    return json.dumps(scene.model_dump(mode="json"), indent=2, sort_keys=True) + "\n"
