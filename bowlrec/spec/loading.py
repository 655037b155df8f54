"""Reading and writing spec files (.json, .yaml, .yml).

:func:`read_mapping` is the one reader of every user file (scenes, jobs, sessions, balls): a
problem with the file itself (not JSON/YAML, a YAML alias or tag, nesting too deep, not UTF-8)
is a :class:`SpecFileError` with one line that says what and where (line and column), never a
traceback. It parses; it does not validate: a scene is validated where every scene comes in,
:mod:`bowlrec.scene_input`. PyYAML is imported on the first YAML file.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.errors import SpecFileError

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["MAX_NESTING", "SpecFileError", "dump_scene_json", "read_mapping"]

_YAML_SUFFIXES = {".yaml", ".yml"}
#: deepest nesting of lists and mappings a spec file may have (a job is about 8 levels deep)
MAX_NESTING = 64


def read_mapping(path: str | Path) -> Any:
    """The parsed content of a JSON or YAML file (not validated); SpecFileError when the file
    is not valid JSON/YAML, uses YAML aliases or tags, is nested deeper than
    :data:`MAX_NESTING` levels, or is not UTF-8 text.

    YAML aliases (``*name``) are refused: they let a few hundred bytes expand to gigabytes
    once the document is validated (the "billion laughs" pattern). Only the standard YAML
    types are constructed (``yaml.SafeLoader``), so tags such as ``!!python/object`` are
    refused too."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix != ".json" and suffix not in _YAML_SUFFIXES:
        raise SpecFileError(f"unsupported scene file type {suffix!r} (use .json, .yaml or .yml)")
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise SpecFileError(f"not UTF-8 text (byte {err.start}: {err.reason})") from None
    try:
        data = _parse_json(text) if suffix == ".json" else _parse_yaml(text)
    except RecursionError:
        raise SpecFileError(f"nested deeper than {MAX_NESTING} levels") from None
    if _depth_exceeds(data, MAX_NESTING):
        raise SpecFileError(f"nested deeper than {MAX_NESTING} levels")
    return data


def _parse_json(text: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise SpecFileError(
            f"not valid JSON: line {err.lineno}, column {err.colno}: {err.msg}"
        ) from None


def _parse_yaml(text: str) -> Any:
    import yaml

    try:
        return yaml.load(text, Loader=_loader_class())  # noqa: S506 - a SafeLoader subclass
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = err.problem or err.context or "invalid YAML"
        raise SpecFileError(f"not valid YAML: {where}{problem}") from None
    except yaml.YAMLError as err:
        raise SpecFileError(f"not valid YAML: {' '.join(str(err).split())}") from None


@functools.cache
def _loader_class() -> type:
    """A ``yaml.SafeLoader`` that refuses aliases (built once, on first use)."""
    import yaml
    from yaml.composer import ComposerError

    class NoAliasLoader(yaml.SafeLoader):
        def compose_node(self, parent: Any, index: Any) -> Any:
            if self.check_event(yaml.AliasEvent):
                event = self.peek_event()
                raise ComposerError(
                    None,
                    None,
                    f"YAML aliases (*{event.anchor}) are not supported; write the value out",
                    event.start_mark,
                )
            return super().compose_node(parent, index)

    return NoAliasLoader


def _depth_exceeds(data: Any, limit: int) -> bool:
    """True when lists/mappings nest deeper than ``limit`` (iterative: no recursion limit)."""
    stack = [(data, 1)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children: Any = node.values()
        elif isinstance(node, list):
            children = node
        else:
            continue
        if depth > limit:
            return True
        stack.extend((child, depth + 1) for child in children)
    return False


def dump_scene_json(scene: Scene) -> str:
    """Canonical JSON text of a scene: indent 2, sorted keys, trailing newline."""
    return json.dumps(scene.model_dump(mode="json"), indent=2, sort_keys=True) + "\n"
