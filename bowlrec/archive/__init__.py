"""Trajectory archives: runs as HDF5 files, an SQLite index and a versioned ball-spec library.

See docs/archive-format.md for the on-disk format and :class:`Archive` for the API.
"""

from .balls import BallEntry, BallLibrary, BallNotFoundError, ball_sha, parse_ball_ref
from .index import Filter
from .location import default_archive_path
from .run_id import run_id
from .store import ARCHIVE_FORMAT, AddResult, Archive, ArchiveError, RunNotFoundError

__all__ = [
    "ARCHIVE_FORMAT",
    "AddResult",
    "Archive",
    "ArchiveError",
    "BallEntry",
    "BallLibrary",
    "BallNotFoundError",
    "Filter",
    "RunNotFoundError",
    "ball_sha",
    "default_archive_path",
    "parse_ball_ref",
    "run_id",
]
