"""The index derived from the data files: the segments, the ball files, the tombstones and the
quarantine reports. Built whole, on disk (:func:`rebuild_index`, by a writer) or in memory
(:func:`read_index`, for a reader whose index file is missing or unreadable: reads never
write); the same steps, applied to what an index lacks, are recovery's (:mod:`.maintenance`).
"""

from __future__ import annotations

import logging
import sqlite3
from collections.abc import Iterable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from bowlrec.errors import IndexUnreadableError, SegmentError

from . import faults
from .ball_files import ball_file_row
from .directory import ArchiveDir
from .index import (
    INDEX_FORMAT,
    PIN_INDEXES,
    RUN_TABLE_COLUMNS,
    create_schema,
    new_index,
    transaction,
)
from .quarantine import UNKNOWN_RUN, quarantine_reports
from .tombstones import Tombstone, read_tombstones

__all__ = [
    "apply_tombstone_files",
    "index_ball_files",
    "memory_index",
    "promote_copies",
    "read_index",
    "rebuild_index",
    "record_tombstones",
    "register_segment_files",
    "upgrade_index",
]

log = logging.getLogger(__package__)  # "bowlrec.archive"


def now() -> str:
    """The time now, ISO 8601 UTC to the second (damage and quarantine records)."""
    return datetime.now(UTC).isoformat(timespec="seconds")


def segment_files(d: ArchiveDir) -> list[Path]:
    """Sealed segment files, oldest first (segment IDs sort by creation time)."""
    if not d.segments_dir.is_dir():
        return []
    return sorted(d.segments_dir.glob("*.h5"))


def record_damage(con: sqlite3.Connection, segment_id: str, run_id: str, reason: str) -> None:
    """List a damaged copy (``runs list --damaged``); ``run_id`` "?" for a segment whose runs
    are not known."""
    con.execute(
        "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
        "VALUES (?, ?, ?, ?)",
        (segment_id, run_id, reason, now()),
    )


def record_tombstones(con: sqlite3.Connection, entries: Iterable[Tombstone]) -> set[str]:
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
            record_damage(con, e.segment_id, e.run_id, e.reason)
    return orphaned


def promote_copies(d: ArchiveDir, con: sqlite3.Connection, run_ids: Iterable[str]) -> int:
    """Index a duplicate copy of each run ID that has no live copy (if one exists)."""
    from .registry import INSERT_RUN, index_rows
    from .segment_file import SegmentFile

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
                with SegmentFile(d.root / rel) as seg:
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


def apply_tombstone_files(d: ArchiveDir, con: sqlite3.Connection) -> int:
    """Record tombstone files the index has not seen; drop the copies they name. The count."""
    seen = {r[0] for r in con.execute("SELECT name FROM tombstone_files")}
    n = 0
    for path, entries in read_tombstones(d.tombstones_dir, skip=seen):
        orphaned = record_tombstones(con, entries)
        promote_copies(d, con, orphaned)
        con.execute("INSERT OR IGNORE INTO tombstone_files (name) VALUES (?)", (path.name,))
        n += 1
    return n


def index_ball_files(d: ArchiveDir, con: sqlite3.Connection, *, only_new: bool) -> int:
    """Index the ball files (``only_new``: those the index lacks); the count. Unreadable ball
    files are skipped."""
    known = (
        {(r[0], int(r[1])) for r in con.execute("SELECT name, version FROM balls")}
        if only_new
        else set()
    )
    n = 0
    for path in sorted(d.balls_dir.glob("*/*.json")) if d.balls_dir.is_dir() else []:
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


def register_segment_files(
    d: ArchiveDir,
    con: sqlite3.Connection,
    *,
    only_new: bool,
    skip: set[str] | frozenset[str] = frozenset(),
) -> tuple[int, list[dict[str, str]]]:
    """Register the segment files (``only_new``: those the index lacks; ``skip``: segment IDs
    left alone): (segments registered, the unreadable ones as {"segment_id", "reason"}, each
    listed as damaged)."""
    from .registry import register_segment

    known = {r[0] for r in con.execute("SELECT segment_id FROM segments")} if only_new else set()
    dead: dict[str, set[str]] = {}
    for seg_id, rid in con.execute("SELECT segment_id, run_id FROM tombstones"):
        dead.setdefault(seg_id, set()).add(rid)
    n, unreadable = 0, []
    for path in segment_files(d):
        if path.stem in known or path.stem in skip:
            continue
        try:
            register_segment(con, path, d.relative(path), dead=dead.get(path.stem, ()))
            n += 1
        except (SegmentError, OSError, KeyError, ValueError) as err:
            reason = f"segment unreadable: {' '.join(str(err).split())}"
            unreadable.append({"segment_id": path.stem, "reason": reason})
            record_damage(con, path.stem, UNKNOWN_RUN, reason)
    return n, unreadable


def _populate(d: ArchiveDir, con: sqlite3.Connection) -> dict[str, Any]:
    """Fill an empty index from the data files; counts, and the unreadable segments."""
    with transaction(con, write=True):
        balls = index_ball_files(d, con, only_new=False)
        tombstones = apply_tombstone_files(d, con)
        for report in quarantine_reports(d.quarantine_dir):
            for item in report.get("damaged", []):
                con.execute(
                    "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
                    "VALUES (?, ?, ?, ?)",
                    (report["segment_id"], item["run_id"], item["reason"], report["at"]),
                )
        segments, unreadable = register_segment_files(d, con, only_new=False)
        # a damaged copy whose run has a healthy copy elsewhere is no longer worth listing
        con.execute("DELETE FROM damaged WHERE run_id IN (SELECT run_id FROM runs)")
        runs = int(con.execute("SELECT COUNT(*) FROM runs").fetchall()[0][0])
    return {
        "runs": runs,
        "segments": segments,
        "balls": balls,
        "tombstone_files": tombstones,
        "segments_unreadable": len(unreadable),
        "unreadable_segments": unreadable,
    }


def rebuild_index(d: ArchiveDir) -> dict[str, Any]:
    """Write a new index from the data files and rename it over the old one (hold the writer
    lock): counts of what was indexed, and the unreadable segments."""
    assert d.locked, "rebuild_index() needs the writer lock"
    tmp = d.new_index_path()
    con = new_index(tmp)
    try:
        con.execute("PRAGMA synchronous=OFF")  # a new file: made durable by install_index
        counts = _populate(d, con)
        con.close()
        faults.point("index-rebuilt", path=tmp)
        d.install_index(tmp)
    except BaseException:
        con.close()
        tmp.unlink(missing_ok=True)
        raise
    return counts


#: the index format :func:`upgrade_index` brings to the current one in place
_UPGRADABLE_FORMAT = "2"


def upgrade_index(d: ArchiveDir) -> bool:
    """Bring an index of format 2 (before pins) to the current format in place, in one
    transaction (hold the writer lock): the ``pinfall`` and ``leave`` columns and their
    indexes added, and filled from the segments that hold pins (format 2.2). A reader sees the
    old index or the new one. False (nothing changed) when the file is not a format-2 index:
    the caller rebuilds it."""
    from .segment_file import SegmentFile

    assert d.locked, "upgrade_index() needs the writer lock"
    if not d.index_path.exists():
        return False
    try:
        con = sqlite3.connect(
            f"file:{d.index_path}?mode=rw", uri=True, timeout=60.0, isolation_level=None
        )
    except sqlite3.OperationalError:
        return False
    try:
        con.execute("PRAGMA journal_mode=DELETE")
        con.execute("PRAGMA synchronous=FULL")
        row = con.execute("SELECT value FROM meta WHERE key = 'index_format'").fetchone()
        if row is None or row[0] != _UPGRADABLE_FORMAT:
            return False
        with transaction(con, write=True):
            have = {r[1] for r in con.execute("PRAGMA table_info(runs)")}
            for name in ("pinfall", "leave"):
                if name not in have:
                    con.execute(f"ALTER TABLE runs ADD COLUMN {name} {RUN_TABLE_COLUMNS[name]}")
            for sql in PIN_INDEXES:
                con.execute(sql)
            segments = con.execute("SELECT seg, path FROM segments").fetchall()
            for seg, rel in segments:
                try:
                    with SegmentFile(d.root / rel) as f:
                        pins = f.pin_index_columns()
                        ids = f.run_ids() if pins is not None else []
                except (SegmentError, OSError, KeyError):
                    continue  # its runs keep no pins; `runs repair` deals with the file
                if pins is None:
                    continue
                con.executemany(
                    # by run ID (its unique index; not a scan per run), this segment's copy
                    "UPDATE runs SET pinfall = ?, leave = ? WHERE run_id = ? AND seg = ?",
                    [
                        (p, leave, rid, seg)
                        for rid, p, leave in zip(
                            ids, pins["pinfall"].tolist(), pins["leave"].tolist(), strict=True
                        )
                        if p is not None
                    ],
                )
            con.execute("UPDATE meta SET value = ? WHERE key = 'index_format'", (INDEX_FORMAT,))
    except sqlite3.DatabaseError:
        return False
    finally:
        con.close()
    return True


def memory_index(d: ArchiveDir) -> sqlite3.Connection:
    """An index built in memory from the data files (nothing is written)."""
    con = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
    con.row_factory = sqlite3.Row
    create_schema(con)
    _populate(d, con)
    return con


def read_index(d: ArchiveDir) -> sqlite3.Connection:
    """The index for reading: the index file opened read-only, or, while it is missing or
    unreadable, an index built in memory from the data files (once per process; a warning
    names the fix). Never writes, never takes the writer lock."""
    try:
        return d.index_reader()
    except IndexUnreadableError as err:
        memory = d.memory_index
        if memory is None:
            log.warning(
                "%s; reading from an index built in memory from the data files (slow for a "
                "large archive): rebuild it with `bowlrec runs reindex`",
                err,
            )
            memory = d.memory_index = memory_index(d)
        return memory
