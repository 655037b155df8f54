"""The index's pin columns and the segment format's version for a run's pins (format 2.2;
docs/archive-format.md, "Pins"). The record groups themselves: :mod:`bowlrec.pins.records`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.pins.records import decoded

__all__ = ["PINS_FORMAT_VERSION", "pin_index_columns"]

#: the minor version a segment declares when it holds a run's pins
PINS_FORMAT_VERSION = "2.2"


def pin_index_columns(
    n: int, group: dict[str, NDArray[Any]] | None
) -> dict[str, NDArray[np.object_]]:
    """The index's ``pinfall`` (int or None) and ``leave`` (text or None) of a segment's n
    runs, as object arrays, from its ``pin_outcome`` group (None: no run of the segment has
    pins)."""
    pinfall: list[Any] = [None] * n
    leave: list[Any] = [None] * n
    if group is not None:
        offsets = np.asarray(group["offsets"])
        falls, names = group["pinfall"], group["leave"]
        for i in range(n):
            a, b = int(offsets[i]), int(offsets[i + 1])
            if b > a:
                pinfall[i] = int(falls[a])
                leave[i] = decoded(names[a])
    return {"pinfall": np.array(pinfall, dtype=object), "leave": np.array(leave, dtype=object)}
