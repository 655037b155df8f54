"""Checking a ball library export (format ``bowlrec-ball-library``) before any of it is added.

:func:`library_items` reads the whole document first, so an import either adds every entry or,
when one entry is invalid, nothing; each problem is one line naming the entry and its field
(``balls[2].spec.mass_kg: ...``, ``balls[0].note: must be text (got int)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from bowlrec.errors import SpecError

from .ball_files import NAME, parse_ball

if TYPE_CHECKING:
    from .ball_files import AnyBall

__all__ = ["LIBRARY_FORMAT", "LIBRARY_FORMAT_VERSION", "checked_ball", "library_items"]

LIBRARY_FORMAT = "bowlrec-ball-library"
LIBRARY_FORMAT_VERSION = 1


def _kind(value: Any) -> str:
    """A JSON value's kind, as the messages name it."""
    names = {dict: "object", list: "array", str: "text", bool: "boolean", type(None): "null"}
    return names.get(type(value), type(value).__name__)


def checked_ball(where: str, spec: Any, joiner: str = ".") -> AnyBall:
    """The ball spec at ``where`` (``balls[i].spec``, a request's ``spec``, a file): a physical
    ball or a bowler spec sheet (``weight_lb``); :class:`~bowlrec.errors.SpecError` naming
    ``where`` when it is not a valid one, each line of a spec's errors as ``where`` +
    ``joiner`` + the field (``balls[0].spec.mass_kg: ...``; a file: ``joiner`` ": ")."""
    from pydantic import ValidationError

    from bowlrec.spec import format_validation_error

    if not isinstance(spec, dict):
        raise SpecError(f"{where}: must be a ball spec object (got {_kind(spec)})")
    try:
        return parse_ball(spec)
    except ValidationError as err:
        lines = format_validation_error(err).splitlines()
        raise SpecError("\n".join(f"{where}{joiner}{line}" for line in lines)) from None
    except SpecError as err:
        raise SpecError(f"{where}: {err}") from None


def library_items(doc: Any) -> list[tuple[str, AnyBall, str]]:
    """(name, spec, note) of every entry of an exported library ``doc``, oldest version of each
    name first. Raises :class:`~bowlrec.errors.SpecError` (one line per problem) for a document
    that is not an export this version reads, or an entry that is not a valid ball."""
    if not isinstance(doc, dict):
        raise SpecError(f"not a ball library export: expected a JSON object (got {_kind(doc)})")
    if doc.get("format") != LIBRARY_FORMAT:
        raise SpecError(
            f"not a ball library export (format = {doc.get('format')!r}, "
            f"expected {LIBRARY_FORMAT!r})"
        )
    version = doc.get("format_version", LIBRARY_FORMAT_VERSION)
    if type(version) is not int or not 1 <= version <= LIBRARY_FORMAT_VERSION:
        raise SpecError(
            f"format_version = {version!r}: this bowlrec reads ball library exports of "
            f"format_version {LIBRARY_FORMAT_VERSION}"
        )
    balls = doc.get("balls", [])
    if not isinstance(balls, list):
        raise SpecError(f"balls: must be an array of balls (got {_kind(balls)})")
    items: list[tuple[str, int, AnyBall, str]] = []
    for i, item in enumerate(balls):
        where = f"balls[{i}]"
        if not isinstance(item, dict):
            raise SpecError(f"{where}: must be an object with name and spec (got {_kind(item)})")
        for field in ("name", "spec"):
            if field not in item:
                raise SpecError(f"{where}.{field}: missing")
        name, note, number = item["name"], item.get("note", ""), item.get("version", 0)
        if not isinstance(name, str) or not NAME.fullmatch(name):
            raise SpecError(
                f"{where}.name = {name!r}: use 1-100 letters, digits, spaces and . _ + - "
                "(starting with a letter or digit)"
            )
        if not isinstance(note, str):
            raise SpecError(f"{where}.note: must be text (got {_kind(note)})")
        if type(number) is not int:
            raise SpecError(f"{where}.version: must be an integer (got {_kind(number)})")
        items.append((name, number, checked_ball(f"{where}.spec", item["spec"]), note))
    items.sort(key=lambda entry: (entry[0], entry[1]))
    return [(name, spec, note) for name, _, spec, note in items]
