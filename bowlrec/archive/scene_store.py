"""Scenes as a segment of format 2.3 stores them: one base scene, and per run only the fields
that differ from it (docs/archive-format.md, "Scenes (2.3)").

A field is named by its path: a JSON array of object keys (strings) and list indices
(integers) from the scene's root, ``["delivery", "omega_radps", 1]``; the empty path is the
whole scene. A run's overrides replace the values at their paths, in order. :func:`diff` finds
the overrides of a scene against the base: objects with the same keys in the same order and
lists of the same length of up to :data:`VECTOR_LENGTH` members (vectors) are compared member by
member, anything else that differs (another type, another key set or key order, a longer list
such as a friction grid's values) is replaced whole, so no override ever deletes a field.
Subtrees are equal when their JSON is: the same types all the way down (``1`` and ``1.0``
differ, and so do ``true`` and ``1``), the same keys in the same order and equal values.

The scene text a reader rebuilds is ``pydantic_core.to_json`` of the base with the overrides
applied: the compact JSON ``Scene.model_dump_json()`` writes, byte for byte, for scenes stored
from a Scene (the number and string texts of one serializer, keys in the base's order).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pydantic_core
from numpy.typing import NDArray

__all__ = ["VECTOR_LENGTH", "Path", "apply", "diff", "path_text", "scene_text", "scene_texts"]

#: a field's path: object keys and list indices from the scene's root
Path = list[str | int]
#: lists up to this long are compared member by member (a vector's components); longer ones
#: that differ are stored whole
VECTOR_LENGTH = 4


def path_text(path: Sequence[str | int]) -> str:
    """A path as the segment stores it (a compact JSON array)."""
    return json.dumps(list(path), separators=(",", ":"))


def diff(base: Any, doc: Any) -> list[tuple[Path, Any]]:
    """The overrides that turn ``base`` into ``doc`` (both parsed JSON), in document order."""
    out: list[tuple[Path, Any]] = []
    _diff(base, doc, [], out)
    return out


def _same_json(a: Any, b: Any) -> bool:
    """Whether two equal (``a == b``) parsed JSON values also write the same JSON text."""
    if type(a) is not type(b):
        return False
    if type(a) is dict:
        return list(a) == list(b) and all(_same_json(a[k], b[k]) for k in a)
    if type(a) is list:
        return all(map(_same_json, a, b))
    return True


def _diff(a: Any, b: Any, path: Path, out: list[tuple[Path, Any]]) -> None:
    same_type = type(a) is type(b)
    if same_type and a == b and _same_json(a, b):  # values in C, then their types and order
        return
    if same_type and type(a) is dict and list(a) == list(b):
        for key in a:
            _diff(a[key], b[key], [*path, key], out)
        return
    if same_type and type(a) is list and len(a) == len(b) <= VECTOR_LENGTH:
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _diff(x, y, [*path, i], out)
        return
    out.append((path, b))


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
    overrides: bytes,
) -> str:
    """One run's scene (compact JSON) from the segment's base, its column overrides (``values``
    at ``paths``; NaN: not overridden) and its other overrides (a JSON array of
    ``[path, value]`` pairs, or empty)."""
    doc = pydantic_core.from_json(base_json)
    for path, value in zip(paths, values, strict=True):
        if not math.isnan(value):
            doc = apply(doc, path, float(value))
    if overrides:
        for path, value in pydantic_core.from_json(overrides):
            doc = apply(doc, path, value)
    return pydantic_core.to_json(doc).decode()


def scene_texts(
    base_json: bytes,
    paths: Sequence[Path],
    values: NDArray[np.float64],
    overrides: NDArray[np.uint8],
    offsets: NDArray[np.int64],
) -> list[str]:
    """Every run's scene of a segment (see :func:`scene_text`)."""
    rows = values.tolist()
    raw = overrides.tobytes()
    ends = offsets.tolist()
    return [
        scene_text(base_json, paths, rows[i], raw[ends[i] : ends[i + 1]])
        for i in range(len(ends) - 1)
    ]
