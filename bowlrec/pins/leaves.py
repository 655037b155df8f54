"""The leave in bowlers' words (interim: pins joined by "-"; replaced by the full naming)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

__all__ = ["name_leave"]


def name_leave(
    standing: Iterable[int], *, hand: Literal["right", "left"] = "right", first_ball: bool = True
) -> str:
    pins = sorted(standing)
    if not pins:
        return "strike" if first_ball else "spare"
    return "-".join(str(p) for p in pins)
