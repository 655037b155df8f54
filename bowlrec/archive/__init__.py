"""Trajectory archives (format 2.0): runs in sealed segment files, a derived SQLite index, a
versioned ball-spec library, tombstones, quarantine and repair.

See docs/archive-format.md for the on-disk format and :class:`Archive` for the API.
"""

from .balls import BallEntry, BallLibrary, BallNotFoundError, ball_sha, parse_ball_ref
from .index import Filter
from .location import default_archive_path
from .run_id import run_id
from .segment import RunRecord, SegmentBuilder, SegmentInfo
from .segment_file import RunDamagedError, SegmentError, SegmentFile
from .store import (
    ARCHIVE_FORMAT,
    ARCHIVE_FORMAT_VERSION,
    AddResult,
    Archive,
    ArchiveError,
    ArchiveWriteError,
    RunNotFoundError,
)

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
    "SegmentError",
    "SegmentFile",
    "SegmentInfo",
    "ball_sha",
    "default_archive_path",
    "parse_ball_ref",
    "run_id",
]
