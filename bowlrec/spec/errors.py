"""Rendering validation errors for people (the CLI, the service and batch jobs).

Pydantic reports a value that fits no member of a union once per member, with the members'
type descriptions in the location (``sweep.tagged-union[...].random.n`` beside
``sweep.list[...]: Input should be a valid list``). :func:`format_validation_error` keeps what a
person needs: the field path without type descriptions, and for a union the member that got
furthest (a type mismatch at a field is dropped when another member's error lies at or below
it; mismatches alone at one field are joined into one line).
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable, Mapping
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

__all__ = ["format_errors", "format_loc", "format_validation_error", "printable"]

#: longest echo of an offending value in a message (its repr), and longest message line
MAX_ECHO = 80
MAX_LINE = 400
#: room a cut line keeps for its note "... (N more characters)"
_CUT_NOTE = 40

# error types whose message already states the offending value
_SELF_DESCRIBING = {"invalid_spec", "value_error", "assertion_error", "missing"}
# location parts Pydantic names after a union member's type rather than a field: a schema tag
# ("list[any]", "function-after[_same_length(), ZipSweep]", "tagged-union[...]"), a plain type,
# or a model class of the spec (its name, e.g. "Linspace")
_TYPE_TAG = re.compile(
    r"(?:list|dict|tuple|set|frozenset|union|tagged-union|nullable|literal|function-\w+|"
    r"lax-or-strict|json-or-python|definition-ref|chain|default|model|is-instance)\[.*\]\Z",
    re.DOTALL,
)
_TYPE_NAMES = {"str", "int", "float", "bool", "none", "bytes"}


def format_loc(loc: tuple[int | str, ...]) -> str:
    """``("ball", "rg_m", 1)`` -> ``"ball.rg_m[1]"``; the root is ``"scene"``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "scene"


def _is_type_part(part: int | str, models: frozenset[str]) -> bool:
    """A location part that names a union member's type (``list[any]``, ``Linspace``,
    ``function-after[...]``), not a field or a key the user wrote (``delivery.omega_radps[1]``
    as a sweep axis, ``Mass`` as an unknown field)."""
    if not isinstance(part, str):
        return False
    return part in _TYPE_NAMES or bool(_TYPE_TAG.match(part)) or part in models


def _model_names() -> frozenset[str]:
    """Names of bowlrec's Pydantic models imported so far (union members are located by
    them; computed per message, since models load lazily)."""
    names: set[str] = set()
    stack: list[type] = [BaseModel]
    while stack:
        cls = stack.pop()
        subclasses: list[type] = cls.__subclasses__()
        for sub in subclasses:
            stack.append(sub)
            if sub.__module__.startswith("bowlrec."):
                names.add(sub.__name__)
    return frozenset(names)


def _model_named(name: str) -> type[BaseModel] | None:
    """bowlrec's Pydantic model of that class name (a ValidationError's ``title``), if any."""
    stack: list[type[BaseModel]] = [BaseModel]
    while stack:
        cls = stack.pop()
        for sub in cls.__subclasses__():
            if sub.__name__ == name and sub.__module__.startswith("bowlrec."):
                return sub
            stack.append(sub)
    return None


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The models a field's annotation can hold (through Optional, unions, lists, tuples,
    dicts and Annotated)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in get_args(annotation) for m in _models_in(arg)]


def _field_names(root: type[BaseModel] | None, loc: tuple[int | str, ...]) -> set[str]:
    """The field names (and aliases) of the mapping at ``loc`` below model ``root`` (empty
    when the place is not a model's)."""
    models: list[type[BaseModel]] = [] if root is None else [root]
    for part in loc:
        if isinstance(part, int):  # an item of a list or tuple: the models it may hold
            continue
        fields = [m.model_fields[part] for m in models if part in m.model_fields]
        models = [m for f in fields[:1] for m in _models_in(f.annotation)]
    names: set[str] = set()
    for m in models:
        for name, info in m.model_fields.items():
            names.add(name if info.alias is None else info.alias)
    return names


def _unknown_field(root: type[BaseModel] | None, parent: tuple[int | str, ...], name: str) -> str:
    """``name`` with a close field name of the mapping at ``parent``, when there is one."""
    from bowlrec.suggest import did_you_mean

    hint = did_you_mean(name, _field_names(root, parent))
    return f"{name} ({hint})" if hint else name


def _is_mismatch(error: dict[str, Any]) -> bool:
    return str(error["type"]).endswith("_type")


def _shows_input(error: Any) -> bool:
    value = error.get("input")
    return error["type"] not in _SELF_DESCRIBING and not isinstance(value, dict | list | BaseModel)


def printable(text: str, limit: int = MAX_LINE) -> str:
    """``text`` safe to print on one line: control and format characters (newlines, NUL,
    bidirectional overrides) escaped, and at most ``limit`` characters, a longer text cut with
    a note of how many characters are left out. Applying it again changes nothing, and it
    reads at most ``limit`` characters of ``text`` however long that is."""
    if len(text) <= limit and text.isprintable():
        return text
    budget = limit - _CUT_NOTE  # room for the note
    pieces: list[str] = []
    size = 0
    kept: int | None = None  # characters of text that fit within the budget
    for i, c in enumerate(text):
        piece = c.encode("unicode_escape").decode("ascii") if _is_control(c) else c
        if kept is None and size + len(piece) > budget:
            kept = i
        size += len(piece)
        if size > limit:
            break
        pieces.append(piece)
    else:
        return "".join(pieces)  # the whole text fits
    assert kept is not None
    return "".join(pieces[:kept]) + f"... ({len(text) - kept:,} more characters)"


def _is_control(c: str) -> bool:
    return unicodedata.category(c).startswith("C")


def _echo(value: Any) -> str:
    """The repr of an offending value, cut after MAX_ECHO characters."""
    try:
        text = repr(value[: 2 * MAX_ECHO] if isinstance(value, str) else value)
    except ValueError:  # an integer too long to print
        return f"a {type(value).__name__} too long to show"
    size = len(value) if isinstance(value, str) else len(text)
    if len(text) <= MAX_ECHO and size <= 2 * MAX_ECHO:
        return text
    return f"{text[:MAX_ECHO]}... ({size:,} characters)"


def _message(error: Mapping[str, Any]) -> str:
    msg = str(error["msg"]).removeprefix("Value error, ")
    if _shows_input(error):
        msg += f" (got {_echo(error['input'])})"
    return msg


def format_validation_error(err: ValidationError) -> str:
    """One line per error, ``"loc: message"``, with the offending value where it helps, e.g.
    ``ball.mass_kg: Input should be greater than 0 (got -1.0)``."""
    return format_errors(err.errors(include_url=False), _model_named(err.title))


def format_errors(details: Iterable[Mapping[str, Any]], root: type[BaseModel] | None = None) -> str:
    """:func:`format_validation_error` for error details (``loc``, ``msg``, ``type``,
    ``input``) as Pydantic and FastAPI report them. Every line is printable (control
    characters escaped, long values cut). With the validated model ``root``, an unknown field
    gets the closest known name (``did you mean 'speed_mph'?``)."""
    errors: list[tuple[tuple[int | str, ...], dict[str, Any]]] = []
    models = _model_names()
    for detail in details:
        loc = tuple(p for p in detail["loc"] if not _is_type_part(p, models))
        errors.append((loc, dict(detail)))
    kept = []
    for loc, e in errors:
        if _is_mismatch(e) and any(
            other is not e
            and loc == o_loc[: len(loc)]
            and (len(o_loc) > len(loc) or not _is_mismatch(other))
            for o_loc, other in errors
        ):
            continue
        kept.append((loc, e))
    # several unknown fields of one mapping: one line naming them all
    extras: dict[tuple[int | str, ...], list[str]] = {}
    for loc, e in kept:
        if e["type"] == "extra_forbidden" and loc:
            extras.setdefault(loc[:-1], []).append(str(loc[-1]))
    lines: dict[tuple[int | str, ...], list[dict[str, Any]]] = {}
    for loc, e in kept:
        if e["type"] == "extra_forbidden" and loc and len(extras[loc[:-1]]) > 1:
            continue
        lines.setdefault(loc, []).append(e)
    out = [
        f"{format_loc(parent)}: Extra inputs are not permitted: "
        + ", ".join(_unknown_field(root, parent, name) for name in names)
        for parent, names in extras.items()
        if len(names) > 1
    ]
    for loc, group in lines.items():
        mismatches = [e for e in group if _is_mismatch(e)]
        if len(mismatches) > 1:
            wants = [str(e["msg"]).removeprefix("Input should be ") for e in mismatches]
            got = mismatches[0].get("input")
            shown = "" if isinstance(got, dict | list) else f" (got {_echo(got)})"
            out.append(f"{format_loc(loc)}: Input should be {', or '.join(wants)}{shown}")
            group = [e for e in group if not _is_mismatch(e)]
        for e in group:
            line = f"{format_loc(loc)}: {_message(e)}"
            if e["type"] == "extra_forbidden" and loc:
                from bowlrec.suggest import did_you_mean

                hint = did_you_mean(str(loc[-1]), _field_names(root, loc[:-1]))
                line += f"; {hint}" if hint else ""
            out.append(line)
    return "\n".join(printable(line) for line in out)
