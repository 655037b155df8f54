"""The pin deck as text: the four rows as the bowler sees them, back row first."""

from __future__ import annotations

from collections.abc import Iterable

from .deck import PIN_ROWS

__all__ = ["deck_diagram"]


def deck_diagram(standing: Iterable[int], set_pins: Iterable[int] = range(1, 11)) -> str:
    """Four lines, back row (7 8 9 10) first, each pin's number where it stands, ``o`` where a
    set pin is down and ``.`` where no pin was set; e.g. a 10 pin leave::

        o  o  o  10
          o  o  o
            o  o
              o
    """
    up, was_set = set(standing), set(set_pins)
    lines = []
    for depth, row in enumerate(reversed(PIN_ROWS)):
        cells = [(str(p) if p in up else "o" if p in was_set else ".").ljust(2) for p in row]
        lines.append(" " * (2 * depth) + " ".join(c for c in cells).rstrip())
    return "\n".join(lines)
