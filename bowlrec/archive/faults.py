"""Named fault points of the archive's write path, where tests replay a crash in-process.

The write path calls :func:`point` at the moments a crash matters (each name in
:data:`POINTS`). Nothing is armed in production: a point is then one test of an empty dict,
once per segment, file or transaction (never per run). A test arms a point with
:func:`armed`; the point then calls the test's action, which raises there (an exception no
``except Exception`` handles stands for a kill; tests/helpers/archive_contract.py) or fails as
the system would (a full disk). What only a real kill shows (a flock released by the OS, a
rollback journal played back) is tested by killing processes (tests/test_archive_faults.py).
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["POINTS", "armed", "point"]

#: every fault point: name -> the moment it marks
POINTS: dict[str, str] = {
    "segment-written": "a segment's datasets written to its temporary, not yet renamed into place",
    "sealed": "a segment sealed (renamed into place), not yet registered",
    "registering": "a segment's rows inserted inside the index transaction, not yet committed",
    "tombstone-written": "a tombstone file written, the index not yet changed",
    "group-commit-sealed": "a group commit's segment sealed, not yet registered",
    "compaction-sealed": "compaction's new segments sealed, the index not yet switched",
    "compaction-switched": "the index switched to compaction's segments, old files not deleted",
    "compaction-deleted": "compaction's old files deleted, their tombstones not yet dropped",
    "repair-salvaged": "repair's salvaged runs sealed, the damaged file not yet moved aside",
    "repair-quarantined": "the damaged file moved to quarantine/, the index not yet switched",
    "index-rebuilt": "a rebuilt index written beside the old one, not yet renamed over it",
}


_armed: dict[str, Callable[..., None]] = {}
_lock = threading.Lock()


def point(name: str, **context: Any) -> None:
    """Mark a fault point; a no-op unless a test armed ``name``. ``context``: what the armed
    action may look at (e.g. ``path``, the file being written)."""
    if _armed:
        action = _armed.get(name)
        if action is not None:
            action(**context)


@contextlib.contextmanager
def armed(name: str, action: Callable[..., None]) -> Iterator[None]:
    """Arm fault point ``name`` for the ``with`` block: ``action(**context)`` runs there.
    Every thread sees the armed point."""
    if name not in POINTS:
        raise ValueError(f"no fault point {name!r}; the points: {', '.join(POINTS)}")
    with _lock:
        if name in _armed:
            raise RuntimeError(f"fault point {name!r} is armed already")
        _armed[name] = action
    try:
        yield
    finally:
        with _lock:
            del _armed[name]
