"""Keeping the index in step with the data files: recovery after a kill, full rebuilds, and
setting copies of runs aside (removal, damage).

- :func:`recover` (cheap, run by the first write of every process): delete temporaries of
  killed writers, apply tombstone files, index ball files and sealed segments the index lacks.
- :func:`rebuild_index`: a new index from the data files alone, written beside the old one and
  renamed over it, so readers see the old index or the new one, never a partial one.
- :func:`kill_copies`: tombstone (segment, run) pairs and drop them from the index; a run whose
  live copy dies but has a duplicate copy elsewhere is served from that copy.

Checksum verification, quarantine and compaction are in :mod:`.repair` and :mod:`.compaction`.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import uuid
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from bowlrec.archive.balls import ball_file_row
from bowlrec.archive.quarantine import quarantine_reports
from bowlrec.atomic_files import fsync_dir, remove_stale_parts
from bowlrec.errors import SegmentError

from .index import create_schema, forget_connections, new_index, transaction
from .registry import INSERT_RUN, index_rows, register_segment
from .segment_file import SegmentFile
from .tombstones import Tombstone, read_tombstones, write_tombstone

if TYPE_CHECKING:
    from .store import Archive

__all__ = ["kill_copies", "memory_index", "rebuild_index", "recover"]


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _segment_files(archive: Archive) -> list[Path]:
    """Sealed segment files, oldest first (segment IDs sort by creation time)."""
    if not archive.segments_dir.is_dir():
        return []
    return sorted(archive.segments_dir.glob("*.h5"))


def _apply_tombstone_files(archive: Archive, con: sqlite3.Connection) -> int:
    """Record tombstone files the index has not seen; drop the copies they name. The count."""
    seen = {r[0] for r in con.execute("SELECT name FROM tombstone_files")}
    n = 0
    for path, entries in read_tombstones(archive.tombstones_dir, skip=seen):
        orphaned = _record_tombstones(con, entries)
        promote_copies(archive, con, orphaned)
        con.execute("INSERT OR IGNORE INTO tombstone_files (name) VALUES (?)", (path.name,))
        n += 1
    return n


def _record_tombstones(con: sqlite3.Connection, entries: Iterable[Tombstone]) -> set[str]:
    """Insert tombstones, drop the copies they name; the run IDs that lost their live copy."""
    orphaned: set[str] = set()
    for e in entries:
        con.execute(
            "INSERT OR REPLACE INTO tombstones (segment_id, run_id, reason) VALUES (?, ?, ?)",
            (e.segment_id, e.run_id, e.reason),
        )
        cur = con.execute(
            "DELETE FROM runs WHERE run_id = ? AND seg = "
            "(SELECT seg FROM segments WHERE segment_id = ?)",
            (e.run_id, e.segment_id),
        )
        if cur.rowcount:
            orphaned.add(e.run_id)
        con.execute(
            "DELETE FROM shadowed WHERE run_id = ? AND segment_id = ?", (e.run_id, e.segment_id)
        )
        if e.reason.startswith("damaged"):
            con.execute(
                "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
                "VALUES (?, ?, ?, ?)",
                (e.segment_id, e.run_id, e.reason, _now()),
            )
    return orphaned


def promote_copies(archive: Archive, con: sqlite3.Connection, run_ids: Iterable[str]) -> int:
    """Index a duplicate copy of each run ID that has no live copy (if one exists)."""
    promoted = 0
    for rid in run_ids:
        if con.execute("SELECT 1 FROM runs WHERE run_id = ?", (rid,)).fetchall():
            continue
        copies = con.execute(
            "SELECT sh.segment_id, sh.row, s.path, s.seg FROM shadowed sh "
            "JOIN segments s ON s.segment_id = sh.segment_id WHERE sh.run_id = ? "
            "ORDER BY sh.segment_id",
            (rid,),
        ).fetchall()
        for segment_id, row, rel, key in copies:
            try:
                with SegmentFile(archive.root / rel) as seg:
                    rows = index_rows(con, int(key), seg.index_columns())
            except (SegmentError, OSError):
                continue
            con.execute(INSERT_RUN, rows[int(row)])
            con.execute(
                "DELETE FROM shadowed WHERE run_id = ? AND segment_id = ?", (rid, segment_id)
            )
            promoted += 1
            break
    return promoted


def kill_copies(archive: Archive, con: sqlite3.Connection, entries: Sequence[Tombstone]) -> None:
    """Tombstone copies of runs (a durable file first, then the index), holding the writer
    lock; runs that lose their live copy fall back to a duplicate copy where one exists."""
    path = write_tombstone(archive.tombstones_dir, entries)
    if path is None:
        return
    with transaction(con, write=True):
        orphaned = _record_tombstones(con, entries)
        con.execute("INSERT OR IGNORE INTO tombstone_files (name) VALUES (?)", (path.name,))
        promote_copies(archive, con, orphaned)


def _ball_files(archive: Archive) -> list[Path]:
    if not archive.balls_dir.is_dir():
        return []
    return sorted(archive.balls_dir.glob("*/*.json"))


def _index_ball_files(archive: Archive, con: sqlite3.Connection, *, only_new: bool) -> int:

    known = (
        {(r[0], int(r[1])) for r in con.execute("SELECT name, version FROM balls")}
        if only_new
        else set()
    )
    n = 0
    for path in _ball_files(archive):
        if not path.stem.isdigit() or (path.parent.name, int(path.stem)) in known:
            continue
        try:
            row = ball_file_row(path)
        except (OSError, ValueError, KeyError, TypeError):
            continue
        con.execute(
            "INSERT OR REPLACE INTO balls (name, version, sha, spec_json, added_at, note) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            row,
        )
        n += 1
    return n


def _register_new_segments(
    archive: Archive, con: sqlite3.Connection, *, only_new: bool
) -> tuple[int, list[str]]:
    """Register segment files the index lacks: (segments registered, unreadable files)."""
    known = {r[0] for r in con.execute("SELECT segment_id FROM segments")} if only_new else set()
    dead: dict[str, set[str]] = {}
    for seg_id, rid in con.execute("SELECT segment_id, run_id FROM tombstones"):
        dead.setdefault(seg_id, set()).add(rid)
    n, unreadable = 0, []
    for path in _segment_files(archive):
        if path.stem in known:
            continue
        try:
            register_segment(
                con, path, str(path.relative_to(archive.root)), dead=dead.get(path.stem, ())
            )
            n += 1
        except (SegmentError, OSError, KeyError, ValueError) as err:
            unreadable.append(f"{path.name}: {err}")
            con.execute(
                "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
                "VALUES (?, '?', ?, ?)",
                (path.stem, f"segment unreadable: {err}", _now()),
            )
    return n, unreadable


#: seconds a locked-kind temporary must have existed before an unlocked one is deemed dead
#: (its writer creates it, then locks it: microseconds apart)
LOCKED_PART_AGE_S = 0.2


def recover(archive: Archive, con: sqlite3.Connection, *, min_age_s: float = 2.0) -> dict[str, int]:
    """Finish what killed writers left (the caller holds the writer lock). Counts of each.

    Segment temporaries are written under a lock, so an unlocked one is a killed writer's
    once it is older than the instant between its creation and its lock
    (:data:`LOCKED_PART_AGE_S`, or ``min_age_s`` if smaller: 0 when the caller knows no writer
    runs); other temporaries are removed once ``min_age_s`` old."""
    removed = sum(
        remove_stale_parts(
            d,
            min_age_s=min(min_age_s, LOCKED_PART_AGE_S) if d == archive.segments_dir else min_age_s,
        )
        for d in (archive.segments_dir, archive.balls_dir, archive.tombstones_dir)
        if d.is_dir()
    )
    with transaction(con, write=True):
        tombstones = _apply_tombstone_files(archive, con)
        balls = _index_ball_files(archive, con, only_new=True)
        segments, unreadable = _register_new_segments(archive, con, only_new=True)
    return {
        "temporaries_removed": removed,
        "tombstone_files_applied": tombstones,
        "ball_files_indexed": balls,
        "segments_registered": segments,
        "segments_unreadable": len(unreadable),
    }


def _populate(archive: Archive, con: sqlite3.Connection) -> dict[str, int]:

    with transaction(con, write=True):
        balls = _index_ball_files(archive, con, only_new=False)
        tombstones = _apply_tombstone_files(archive, con)
        for report in quarantine_reports(archive):
            for item in report.get("damaged", []):
                con.execute(
                    "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
                    "VALUES (?, ?, ?, ?)",
                    (report["segment_id"], item["run_id"], item["reason"], report["at"]),
                )
        segments, unreadable = _register_new_segments(archive, con, only_new=False)
        # a damaged copy whose run has a healthy copy elsewhere is no longer worth listing
        con.execute("DELETE FROM damaged WHERE run_id IN (SELECT run_id FROM runs)")
    return {
        "balls": balls,
        "tombstone_files": tombstones,
        "segments": segments,
        "segments_unreadable": len(unreadable),
    }


def rebuild_index(archive: Archive) -> dict[str, int]:
    """Write a new index from the data files and rename it over the old one (hold the writer
    lock). Counts of what was indexed."""
    for leftover in archive.root.glob(f"{archive.index_path.name}.rebuild-*"):
        leftover.unlink(missing_ok=True)  # left by a rebuild that was killed (we hold the lock)
    tmp = archive.index_path.with_name(f"{archive.index_path.name}.rebuild-{uuid.uuid4().hex[:8]}")
    con = new_index(tmp)
    try:
        con.execute("PRAGMA synchronous=OFF")  # a new file: made durable by the fsync below
        counts = _populate(archive, con)
        con.close()
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        forget_connections(archive.index_path)
        for stale in ("-journal", "-wal", "-shm"):  # belong to the file being replaced
            with contextlib.suppress(FileNotFoundError):
                archive.index_path.with_name(archive.index_path.name + stale).unlink()
        os.replace(tmp, archive.index_path)
        fsync_dir(archive.root)
    except BaseException:
        con.close()
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    return counts


def memory_index(archive: Archive) -> sqlite3.Connection:
    """An index built in memory from the data files (for readers who may not write)."""
    con = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
    con.row_factory = sqlite3.Row
    create_schema(con)
    _populate(archive, con)
    return con
