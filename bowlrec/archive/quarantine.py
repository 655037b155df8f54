"""The reports that ``runs repair`` leaves next to a quarantined segment, and how to read them.

A report is a JSON document in the archive's ``quarantine/`` folder with ``format`` =
:data:`QUARANTINE_FORMAT`, naming the segment and each damaged run; repair writes them,
maintenance (rebuilding the index) and compaction read them.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .store import Archive

__all__ = ["QUARANTINE_FORMAT", "quarantine_reports"]

QUARANTINE_FORMAT = "bowlrec-quarantine"


def quarantine_reports(archive: Archive) -> Iterator[dict[str, Any]]:
    """The reports of quarantined segments (oldest first)."""
    if not archive.quarantine_dir.is_dir():
        return
    for path in sorted(archive.quarantine_dir.glob("*.json")):
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict) and doc.get("format") == QUARANTINE_FORMAT:
            yield doc
