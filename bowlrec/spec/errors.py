"""Rendering validation errors for people (the CLI)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ValidationError

__all__ = ["format_loc", "format_validation_error"]

# error types whose message already states the offending value
_SELF_DESCRIBING = {"invalid_spec", "value_error", "assertion_error", "missing"}


def format_loc(loc: tuple[int | str, ...]) -> str:
    """``("ball", "rg_m", 1)`` -> ``"ball.rg_m[1]"``; the root is ``"scene"``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "scene"


def _shows_input(error: Any) -> bool:
    value = error.get("input")
    return error["type"] not in _SELF_DESCRIBING and not isinstance(value, dict | list | BaseModel)


def format_validation_error(err: ValidationError) -> str:
    """One line per error, ``"loc: message"``, with the offending value where it helps, e.g.
    ``ball.mass_kg: Input should be greater than 0 (got -1.0)``."""
    lines = []
    for e in err.errors(include_url=False):
        msg = str(e["msg"]).removeprefix("Value error, ")
        if _shows_input(e):
            msg += f" (got {e['input']!r})"
        lines.append(f"{format_loc(tuple(e['loc']))}: {msg}")
    return "\n".join(lines)
