"""The reports that ``runs repair`` leaves next to a quarantined segment, and how to read them.

A report is a JSON document in the archive's ``quarantine/`` folder with ``format`` =
:data:`QUARANTINE_FORMAT`, naming the segment and each damaged run (run ID ``"?"`` when the
segment could not be read at all and its runs were not indexed); repair writes them, rebuilding
the index, recovery and compaction read them.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["QUARANTINE_FORMAT", "UNKNOWN_RUN", "quarantine_reports"]

QUARANTINE_FORMAT = "bowlrec-quarantine"
#: the run ID a damage record carries when the segment's runs are not known
UNKNOWN_RUN = "?"


def quarantine_reports(directory: Path) -> Iterator[dict[str, Any]]:
    """The reports in ``directory`` (an archive's ``quarantine/``), oldest first."""
    if not directory.is_dir():
        return
    for path in sorted(directory.glob("*.json")):
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict) and doc.get("format") == QUARANTINE_FORMAT:
            yield doc
