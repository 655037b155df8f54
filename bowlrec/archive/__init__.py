"""Trajectory archives (format 2.0): runs in sealed segment files, a derived SQLite index, a
versioned ball-spec library, tombstones, quarantine and repair.

See docs/archive-format.md for the on-disk format and :class:`Archive` for the API. Names are
imported on first use, so listing an archive's index never loads NumPy or h5py.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from bowlrec.errors import (
    ArchiveError,
    ArchiveWriteError,
    BallNotFoundError,
    RunDamagedError,
    RunNotFoundError,
    SegmentError,
)

# the function, not its module: ``bowlrec.archive.run_id`` would otherwise become the module
# ``run_id.py`` as soon as anything imported it (a submodule import sets the package attribute)
from .run_id import run_id

if TYPE_CHECKING:
    from .balls import BallEntry, BallLibrary, ball_sha, parse_ball_ref
    from .index import Filter
    from .location import default_archive_path
    from .segment import RunRecord, SegmentBuilder, SegmentInfo, SummaryRuns
    from .segment_file import SegmentFile
    from .store import (
        ARCHIVE_FORMAT,
        ARCHIVE_FORMAT_VERSION,
        AddResult,
        Archive,
    )

#: public name -> the module that defines it
_WHERE = {
    "ARCHIVE_FORMAT": "store",
    "ARCHIVE_FORMAT_VERSION": "store",
    "AddResult": "store",
    "Archive": "store",
    "BallEntry": "balls",
    "BallLibrary": "balls",
    "Filter": "index",
    "RunRecord": "segment",
    "SegmentBuilder": "segment",
    "SummaryRuns": "segment",
    "SegmentFile": "segment_file",
    "SegmentInfo": "segment",
    "ball_sha": "balls",
    "default_archive_path": "location",
    "parse_ball_ref": "balls",
}

__all__ = [
    "ARCHIVE_FORMAT",
    "ARCHIVE_FORMAT_VERSION",
    "AddResult",
    "Archive",
    "ArchiveError",
    "ArchiveWriteError",
    "BallEntry",
    "BallLibrary",
    "BallNotFoundError",
    "Filter",
    "RunDamagedError",
    "RunNotFoundError",
    "RunRecord",
    "SegmentBuilder",
    "SummaryRuns",
    "SegmentError",
    "SegmentFile",
    "SegmentInfo",
    "ball_sha",
    "default_archive_path",
    "parse_ball_ref",
    "run_id",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'bowlrec.archive' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
