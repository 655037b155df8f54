"""Field paths of a job's sweep: ``"delivery.omega_radps[1]"`` parsed and applied to a scene.

A path is field names separated by dots and vector elements as ``[i]``; applying an override
sets that field of a full scene mapping in place, and a path that addresses no field is a
:class:`~bowlrec.errors.JobError` naming the fields there (or the vector's length).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

from bowlrec.errors import JobError

__all__ = ["PathKey", "apply_override", "parse_path", "path_label"]

#: one step of a path: a field name or a vector index
PathKey = str | int

_PATH = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*|\[\d+\])*")
_KEY = re.compile(r"([A-Za-z_]\w*)|\[(\d+)\]")


def parse_path(path: str) -> tuple[PathKey, ...]:
    """``"delivery.omega_radps[1]"`` -> ``("delivery", "omega_radps", 1)``."""
    if not _PATH.fullmatch(path):
        raise JobError(
            f"path {path!r} is not a field path: write field names separated by dots and vector "
            "elements as [i], e.g. 'delivery.speed_mps' or 'delivery.omega_radps[1]'"
        )
    return tuple(
        m.group(1) if m.group(1) is not None else int(m.group(2)) for m in _KEY.finditer(path)
    )


def path_label(keys: Sequence[PathKey]) -> str:
    """The path of ``keys`` as written: ``("delivery", "omega_radps", 1)`` ->
    ``"delivery.omega_radps[1]"``."""
    out = ""
    for k in keys:
        out += f"[{k}]" if isinstance(k, int) else (f".{k}" if out else k)
    return out


def apply_override(data: dict[str, Any], path: str, value: Any) -> None:
    """Set ``path`` in the full scene mapping ``data`` (in place); JobError if it does not
    address an existing field (the message lists the fields or the vector length)."""
    keys = parse_path(path)
    node: Any = data
    for depth, key in enumerate(keys):
        where = path_label(keys[:depth]) or "the scene"
        last = depth == len(keys) - 1
        if isinstance(key, str):
            if not isinstance(node, dict):
                kind = "null" if node is None else type(node).__name__
                raise JobError(
                    f"path {path!r}: {where} is {kind} in the base scene, it has no field "
                    f"{key!r} (set {where} in the base scene, or sweep it whole)"
                )
            if key not in node:
                raise JobError(
                    f"path {path!r}: {where} has no field {key!r}; fields: {', '.join(node)}"
                )
        else:
            if not isinstance(node, list):
                kind = "null" if node is None else type(node).__name__
                raise JobError(
                    f"path {path!r}: {where} is {kind} in the base scene, not a vector; "
                    f"[{key}] needs a vector (set {where} in the base scene, or sweep it whole)"
                )
            if key >= len(node):
                raise JobError(
                    f"path {path!r}: {where} has {len(node)} elements, index {key} is out of "
                    f"range (0..{len(node) - 1})"
                )
        if last:
            node[key] = value
        else:
            node = node[key]


# -- loading ------------------------------------------------------------------------------------
