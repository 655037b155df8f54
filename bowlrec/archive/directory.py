"""The archive directory, the bottom of the archive: its paths, its marker (``archive.json``),
the writer lock, the index connections and the segments kept open for reading.

It knows the files, not what is written into them: writing runs, queries, maintenance and
repair are the modules above (docs/archive-format.md, "Code layout of the archive"), each
taking an :class:`ArchiveDir`.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sqlite3
import threading
import uuid
from collections import OrderedDict
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.atomic_files import atomic_path, fsync_dir
from bowlrec.errors import ArchiveError, ArchiveWriteError

from .index import forget_connections, new_index, open_index

if TYPE_CHECKING:
    from .segment_file import SegmentFile

__all__ = ["ARCHIVE_FORMAT", "ARCHIVE_FORMAT_VERSION", "ArchiveDir", "read_marker"]

ARCHIVE_FORMAT = "bowlrec-archive"
ARCHIVE_FORMAT_VERSION = "2.0"
#: what a directory may hold before its marker is written (a creation in progress, or one
#: killed before it wrote the marker): such a directory is completed, not refused
_ARCHIVE_ENTRIES = {
    ".writer.lock",
    "segments",
    "balls",
    "tombstones",
    "index.sqlite",
    "index.sqlite-journal",
}
#: segments kept open for reading, at most
_OPEN_SEGMENTS = 8


def read_marker(marker: Path) -> dict[str, Any]:
    """The archive marker's document (ArchiveError when it is unreadable or not a marker)."""
    try:
        meta = json.loads(marker.read_text())
    except (OSError, ValueError) as err:
        raise ArchiveError(f"{marker}: unreadable archive marker ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != ARCHIVE_FORMAT:
        raise ArchiveError(f"{marker}: not a bowlrec archive marker")
    return meta


class ArchiveDir:
    """An archive directory (created on first use unless ``create`` is False).

    Besides the files it keeps, per process, what the modules above share: the in-memory
    index a reader falls back to (:attr:`memory_index`) and whether this process's first write
    has recovered what killed writers left (:attr:`recovered`, :attr:`unreported_recovery`).
    """

    def __init__(self, root: str | os.PathLike[str], *, create: bool = True) -> None:
        self.root = Path(root).expanduser()
        self.marker = self.root / "archive.json"
        self.segments_dir = self.root / "segments"
        self.balls_dir = self.root / "balls"
        self.tombstones_dir = self.root / "tombstones"
        self.quarantine_dir = self.root / "quarantine"
        self.index_path = self.root / "index.sqlite"
        self.lock_path = self.root / ".writer.lock"
        self._lock = threading.RLock()
        self._lock_depth = 0
        self._lock_file: Any = None
        self._segments: OrderedDict[Path, SegmentFile] = OrderedDict()
        self._segments_lock = threading.Lock()
        #: an index built in memory from the data files, read while the index file is
        #: missing or unreadable (set by :func:`~.rebuild.read_index`)
        self.memory_index: sqlite3.Connection | None = None
        #: True once this process has recovered what killed writers left (its first write)
        self.recovered = False
        #: counts of recoveries this process ran on its first write that no explicit
        #: recover(), repair() or reindex() has reported yet
        self.unreported_recovery: dict[str, int] = {}
        if not self.marker.exists():
            if not create:
                raise ArchiveError(f"{self.root} is not a bowlrec archive (no archive.json)")
            if self.root.exists() and not self.root.is_dir():
                raise ArchiveError(f"{self.root} is a file, not an archive directory")
            try:
                self._create()
            except OSError as err:  # a read-only parent, a place like /proc, a full disk
                reason = err.strerror or str(err)
                raise ArchiveWriteError(
                    f"{self.root}: cannot create an archive here ({reason})"
                ) from None
        version = str(read_marker(self.marker).get("format_version", ""))
        major, ours = version.split(".")[0], ARCHIVE_FORMAT_VERSION.split(".")[0]
        if major == "1":
            raise ArchiveError(
                f"{self.root} is a format {version} archive; this bowlrec reads format "
                f"{ours}.x. Convert it once with: bowlrec archive migrate {self.root}"
            )
        if major != ours:
            raise ArchiveError(
                f"{self.root}: archive format {version} is not supported (this bowlrec "
                f"reads {ours}.x)"
            )
        self.format_version = version

    def __repr__(self) -> str:
        return f"ArchiveDir({str(self.root)!r})"

    def _create(self) -> None:
        """Make a new archive; safe when several processes create the same one at once. The
        index starts empty; where data files are already present (a creation killed and
        resumed) it is left for the first writer to build from them."""
        self.root.mkdir(parents=True, exist_ok=True)
        with self.writer_lock():
            if self.marker.exists():
                return  # another process created it while this one waited for the lock
            strangers = [
                p.name
                for p in self.root.iterdir()
                if p.name not in _ARCHIVE_ENTRIES and not p.name.startswith("index.sqlite.")
            ]
            if strangers:
                raise ArchiveError(
                    f"{self.root} exists, is not empty and is not a bowlrec archive; "
                    "choose an empty or new directory"
                )
            for d in (self.segments_dir, self.balls_dir, self.tombstones_dir):
                d.mkdir(exist_ok=True)
            if not any(any(d.iterdir()) for d in (self.segments_dir, self.balls_dir)):
                tmp = self.new_index_path()
                new_index(tmp).close()
                self.install_index(tmp)
            with atomic_path(self.marker) as tmp:
                doc = {"format": ARCHIVE_FORMAT, "format_version": ARCHIVE_FORMAT_VERSION}
                tmp.write_text(json.dumps(doc) + "\n")

    @property
    def writable(self) -> bool:
        """True when this process may write the archive directory."""
        return os.access(self.root, os.W_OK)

    def relative(self, path: Path) -> str:
        """``path`` relative to the archive's root (as the index stores it)."""
        return str(path.relative_to(self.root))

    # -- the writer lock ---------------------------------------------------------------------

    @contextlib.contextmanager
    def writer_lock(self) -> Iterator[None]:
        """Exclusive across processes (flock on ``.writer.lock``; released by the OS if the
        holder dies) and threads; re-entrant within a thread."""
        with self._lock:
            if self._lock_depth == 0:
                try:
                    fh = open(self.lock_path, "a")  # noqa: SIM115 - held below
                except OSError as err:
                    raise ArchiveWriteError(
                        f"{self.root}: cannot write to the archive ({err.strerror})"
                    ) from None
                fcntl.flock(fh, fcntl.LOCK_EX)
                self._lock_file = fh
            self._lock_depth += 1
            try:
                yield
            finally:
                self._lock_depth -= 1
                if self._lock_depth == 0:
                    fcntl.flock(self._lock_file, fcntl.LOCK_UN)
                    self._lock_file.close()
                    self._lock_file = None

    @property
    def locked(self) -> bool:
        """True while this process holds the writer lock."""
        return self._lock_depth > 0

    # -- the index file ----------------------------------------------------------------------

    def index_reader(self) -> sqlite3.Connection:
        """A read-only connection to the index file (``mode=ro``: takes no lock file, needs no
        write access). Raises :class:`~bowlrec.errors.IndexUnreadableError` when the file is
        missing, damaged or of another index format."""
        return open_index(self.index_path, write=False)

    def index_writer(self) -> sqlite3.Connection:
        """A writing connection to the index file (hold :meth:`writer_lock`). Raises
        :class:`~bowlrec.errors.IndexUnreadableError` as :meth:`index_reader` does."""
        assert self.locked, "index_writer() needs the writer lock"
        return open_index(self.index_path, write=True)

    def new_index_path(self) -> Path:
        """A fresh path beside the index for a new index file (hold :meth:`writer_lock`);
        what a killed rebuild left there is deleted first."""
        for leftover in self.root.glob(f"{self.index_path.name}.rebuild-*"):
            leftover.unlink(missing_ok=True)
        return self.index_path.with_name(f"{self.index_path.name}.rebuild-{uuid.uuid4().hex[:8]}")

    def install_index(self, tmp: Path) -> None:
        """Rename the finished index file ``tmp`` over the index (fsynced first): a reader
        sees the old index or the new one, never a partial one (hold :meth:`writer_lock`)."""
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        forget_connections(self.index_path)
        for stale in ("-journal", "-wal", "-shm"):  # belong to the file being replaced
            with contextlib.suppress(FileNotFoundError):
                self.index_path.with_name(self.index_path.name + stale).unlink()
        os.replace(tmp, self.index_path)
        fsync_dir(self.root)
        self.memory_index = None

    # -- segments open for reading -----------------------------------------------------------

    def segment(self, path: Path) -> SegmentFile:
        """The segment at ``path``, opened once and kept among the most recently read
        (segments are immutable: a kept handle never goes stale). Safe across threads. Raises
        :class:`~bowlrec.errors.SegmentError` when the file is not a readable segment."""
        from .segment_file import SegmentFile

        with self._segments_lock:
            seg = self._segments.pop(path, None)
            if seg is None:
                seg = SegmentFile(path)
            self._segments[path] = seg
            while len(self._segments) > _OPEN_SEGMENTS:
                # dropped, not closed: another thread may be reading it; HDF5 closes the file
                # when the last reference goes
                self._segments.popitem(last=False)
        return seg

    def close(self) -> None:
        """Close the segment files kept open for reading (reopened when needed)."""
        with self._segments_lock:
            while self._segments:
                self._segments.popitem()[1].close()
