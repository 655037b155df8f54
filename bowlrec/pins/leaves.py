"""The leave in bowlers' words (interim: pins joined by "-"; replaced by the full naming)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

__all__ = ["mirror_pins", "name_leave"]


def name_leave(
    standing: Iterable[int], *, hand: Literal["right", "left"] = "right", first_ball: bool = True
) -> str:
    pins = sorted(standing)
    if not pins:
        return "strike" if first_ball else "spare"
    return "-".join(str(p) for p in pins)


_MIRROR = {1: 1, 2: 3, 3: 2, 4: 6, 5: 5, 6: 4, 7: 10, 8: 9, 9: 8, 10: 7}


def mirror_pins(pins: Iterable[int]) -> tuple[int, ...]:
    return tuple(_MIRROR[p] for p in pins)
