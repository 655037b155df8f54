"""Tombstones: removals recorded as files, so a removed or damaged run never comes back.

Segments are never rewritten in place. Removing a run (or setting a damaged copy aside) writes a
tombstone file ``tombstones/<time>-<random>.json`` naming the (segment, run) pairs it kills and
why; the index drops those rows, and an index rebuilt from the files skips them. Compaction
rewrites segments without their dead rows and then deletes the tombstones it has applied.
"""

from __future__ import annotations

import json
import time
import uuid
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from bowlrec.atomic_files import atomic_path

__all__ = ["TOMBSTONE_FORMAT", "Tombstone", "read_tombstones", "write_tombstone"]

TOMBSTONE_FORMAT = "bowlrec-tombstones"


@dataclass(frozen=True)
class Tombstone:
    """One dead copy of a run: its segment, run ID and the reason ("removed" or "damaged: ...")."""

    segment_id: str
    run_id: str
    reason: str


def write_tombstone(directory: Path, entries: Iterable[Tombstone]) -> Path | None:
    """Write one tombstone file (durably, whole or not at all); None when there is nothing."""
    items = [{"segment_id": e.segment_id, "run_id": e.run_id, "reason": e.reason} for e in entries]
    if not items:
        return None
    path = directory / f"{time.time_ns():016x}-{uuid.uuid4().hex[:8]}.json"
    doc = {"format": TOMBSTONE_FORMAT, "entries": items}
    with atomic_path(path, hold_lock=True) as tmp:
        tmp.write_text(json.dumps(doc) + "\n")
    return path


def read_tombstones(
    directory: Path, *, skip: frozenset[str] | set[str] = frozenset()
) -> Iterator[tuple[Path, list[Tombstone]]]:
    """Every tombstone file with its entries, oldest first, but the file names in ``skip``
    (unreadable files are skipped: a tombstone is written whole, so only a file damaged on
    disk is unreadable)."""
    if not directory.is_dir():
        return
    for path in sorted(directory.glob("*.json")):
        if path.name in skip:
            continue
        try:
            doc = json.loads(path.read_text())
            if doc.get("format") != TOMBSTONE_FORMAT:
                continue
            yield path, [Tombstone(**e) for e in doc["entries"]]
        except (OSError, ValueError, TypeError, KeyError):
            continue
