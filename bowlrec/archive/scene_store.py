"""Scenes as a segment of format 2.3 stores them: one base scene, and per run either the values
of the fields a batch sweeps (columns) or, for a scene that differs from the base otherwise,
the run's whole scene text (docs/archive-format.md, "Scenes (2.3)").

A column's field is named by its path: a JSON array of object keys (strings) and list indices
(integers) from the scene's root, ``["delivery", "omega_radps", 1]``. The scene text a reader
rebuilds from the base and the columns is ``pydantic_core.to_json`` of the base with the
values applied: the compact JSON ``Scene.model_dump_json()`` writes, byte for byte, for scenes
stored from a Scene (the number and string texts of one serializer, keys in the base's order).
A run stored whole reads back as the bytes it was given.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pydantic_core
from numpy.typing import NDArray

__all__ = ["Path", "apply", "path_text", "scene_text", "scene_texts"]

#: a field's path: object keys and list indices from the scene's root
Path = list[str | int]


def path_text(path: Sequence[str | int]) -> str:
    """A path as the segment stores it (a compact JSON array)."""
    return json.dumps(list(path), separators=(",", ":"))


def apply(doc: Any, path: Sequence[str | int], value: Any) -> Any:
    """``doc`` with the value at ``path`` replaced (in place; the empty path returns
    ``value``). KeyError / IndexError / TypeError when the path does not lead into ``doc``."""
    if not path:
        return value
    node = doc
    for step in path[:-1]:
        node = node[step]
    last = path[-1]
    if isinstance(node, list) and not isinstance(last, int):
        raise TypeError(f"list index {last!r} is not an integer")
    node[last] = value
    return doc


def scene_text(
    base_json: bytes,
    paths: Sequence[Path],
    values: Sequence[float],
    whole: bytes,
) -> str:
    """One run's scene (compact JSON): ``whole`` when the run stores its scene whole, else the
    segment's base with the run's column values (``values`` at ``paths``; NaN: the base's)."""
    if whole:
        return whole.decode()
    doc = pydantic_core.from_json(base_json)
    for path, value in zip(paths, values, strict=True):
        if not math.isnan(value):
            doc = apply(doc, path, float(value))
    return pydantic_core.to_json(doc).decode()


def scene_texts(
    base_json: bytes,
    paths: Sequence[Path],
    values: NDArray[np.float64],
    whole: NDArray[np.uint8],
    offsets: NDArray[np.int64],
) -> list[str]:
    """Every run's scene of a segment (see :func:`scene_text`); ``whole``: the scenes stored
    whole, concatenated (run i's is ``whole[offsets[i]:offsets[i + 1]]``, empty for none)."""
    rows = values.tolist()
    raw = whole.tobytes()
    ends = offsets.tolist()
    return [
        scene_text(base_json, paths, rows[i], raw[ends[i] : ends[i + 1]])
        for i in range(len(ends) - 1)
    ]
