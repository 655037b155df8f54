"""What kind of bowlrec file a mapping is, and which command runs it.

A scene, a batch job, a session and a carry map are each read by their own command; given to
another, the file would fail on fields the other kind does not have. The loaders ask
:func:`wrong_kind` first, so the answer is "this is a bowler scene: simulate it with
`bowlrec simulate`" rather than a list of fields the other format does not permit.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["KINDS", "kind_of", "wrong_kind"]

#: kind -> (what it is, the commands that run it)
KINDS: dict[str, tuple[str, str]] = {
    "bowler": (
        "a bowler scene",
        "`bowlrec simulate` (or `bowlrec aim`, `bowlrec variance`, `bowlrec pins`)",
    ),
    "scene": ("a physical scene", "`bowlrec simulate` (or `bowlrec pins`)"),
    "bowlrec-job": ("a batch job", "`bowlrec batch`"),
    "bowlrec-session": ("a session", "`bowlrec session`"),
    "bowlrec-carry": ("a carry map", "`bowlrec carry`"),
}
#: top-level fields that only one kind has (for files that leave ``format`` out)
_SIGNS: tuple[tuple[str, frozenset[str]], ...] = (
    ("bowlrec-session", frozenset({"bowlers", "games"})),
    ("bowlrec-job", frozenset({"base", "sweep", "scenes"})),
    ("bowlrec-carry", frozenset({"angles_deg", "boards", "speeds_mph", "repeats"})),
)
_SCENE_FIELDS = frozenset({"name", "description", "ball", "lane", "delivery", "options", "air"})


def kind_of(data: Any) -> str | None:
    """The kind of a file's mapping (a key of :data:`KINDS`), or None when it is none of them
    (not a mapping, an unknown ``format``, fields of no one kind)."""
    if not isinstance(data, Mapping):
        return None
    fmt = data.get("format")
    if fmt is not None:
        return fmt if isinstance(fmt, str) and fmt in KINDS else None
    for kind, signs in _SIGNS:
        if signs & set(data):
            return kind
    physical = {"lane", "delivery", "options", "air"} & set(data) or isinstance(
        data.get("ball"), Mapping
    )
    if physical and set(data) <= _SCENE_FIELDS:  # a job may also have just a name and a ball
        return "scene"
    return None


def wrong_kind(data: Any, expected: str, *accepted: str) -> str | None:
    """One line when ``data`` is a file of another kind than ``expected`` (or the ``accepted``
    others), naming what it is and the command that runs it; None when it is of the expected
    kind or of no known kind (its own validation then says what is wrong)."""
    kind = kind_of(data)
    if kind is None or kind == expected or kind in accepted:
        return None
    what, commands = KINDS[kind]
    wanted = "a scene" if {"scene", "bowler"} <= {expected, *accepted} else KINDS[expected][0]
    return f"this is {what}, not {wanted}: run it with {commands}"
