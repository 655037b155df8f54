"""A run's scene as a JSON file: the physical scene as simulated, indented (simulating the file
again gives the same run ID)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

from bowlrec.atomic_files import atomic_path

if TYPE_CHECKING:
    from .common import RunData

__all__ = ["write_scene_json"]


def write_scene_json(run: RunData, path: str | os.PathLike[str]) -> Path:
    """Write the scene of ``run`` to ``path`` as indented JSON; return the path."""
    target = Path(path)
    text = json.dumps(json.loads(run.scene_json()), indent=2) + "\n"
    with atomic_path(target) as tmp:
        tmp.write_text(text)
    return target
