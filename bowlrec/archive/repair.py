"""``runs repair``: every stored run's digest checked, the index held against the segments and
the ball files, and damaged segments quarantined without taking their healthy runs with them.

For a segment with damaged runs, in this order (a kill at any point loses nothing healthy; the
next writer's recovery finishes step 3 after a kill between 2 and 3):
1. its healthy runs are rewritten into a new sealed segment (same provenance);
2. the damaged file moves to ``quarantine/`` with a JSON report naming each damaged run;
3. one index transaction drops the old segment, registers the new one, lists the damaged runs
   (``runs list --damaged``) and serves a damaged run from a duplicate copy where one exists.

A segment file that cannot be read at all is quarantined the same way, whether the index
lists its runs (they are named damaged) or not (after an index rebuild: the runs are unknown,
the segment is named).
"""

from __future__ import annotations

import json
import os
import sqlite3
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.atomic_files import atomic_path, fsync_dir
from bowlrec.errors import SegmentError

from . import faults
from .ball_files import ball_file_row
from .directory import ArchiveDir
from .index import transaction
from .maintenance import recover, switch_segment, writer_index
from .quarantine import QUARANTINE_FORMAT, UNKNOWN_RUN
from .rebuild import now, segment_files
from .writing import seal

if TYPE_CHECKING:
    from .segment_file import SegmentFile
    from .segment_format import SegmentInfo

__all__ = ["repair"]


def _provenance(seg: SegmentFile) -> dict[str, Any]:
    skip = {"format", "format_version", "segment_id", "n_runs"}
    return {k: v for k, v in seg.provenance.items() if k not in skip}


def _salvage(d: ArchiveDir, path: Path, rows: list[int]) -> SegmentInfo | None:
    """The runs at ``rows`` of the segment at ``path`` sealed into a new segment."""
    from .segment import SegmentBuilder
    from .segment_file import SegmentFile

    if not rows:
        return None
    with SegmentFile(path) as seg:
        builder = SegmentBuilder(_provenance(seg))
        for rec in seg.read_all(rows):
            builder.append(rec.to_record())
    return seal(d, builder)


def _quarantine(
    d: ArchiveDir,
    con: sqlite3.Connection,
    segment_id: str,
    path: Path,
    damaged: dict[str, str],
    healthy_rows: list[int],
) -> dict[str, Any]:
    """Rewrite the healthy runs, move the file aside, fix the index (see the module doc)."""
    salvaged = _salvage(d, path, healthy_rows)
    faults.point("repair-salvaged", path=path)
    d.quarantine_dir.mkdir(exist_ok=True)
    report = {
        "format": QUARANTINE_FORMAT,
        "segment_id": segment_id,
        "at": now(),
        "damaged": [{"run_id": rid, "reason": why} for rid, why in sorted(damaged.items())],
        "salvaged_into": None if salvaged is None else salvaged.segment_id,
        "salvaged_runs": len(healthy_rows),
    }
    with atomic_path(d.quarantine_dir / f"{segment_id}.json") as tmp:
        tmp.write_text(json.dumps(report, indent=1) + "\n")
    if path.exists():
        os.replace(path, d.quarantine_dir / path.name)
        fsync_dir(d.segments_dir)
    faults.point("repair-quarantined", path=d.quarantine_dir / path.name)
    with transaction(con, write=True):
        switch_segment(d, con, segment_id, damaged, None if salvaged is None else salvaged.path)
    return report


def _unreadable(err: BaseException, path: Path) -> str:
    """Why a segment file cannot be read, in one line."""
    if not path.exists():
        return "segment file missing"
    return f"segment unreadable: {' '.join(str(err).split())}"


def _check_ball_rows(d: ArchiveDir, con: sqlite3.Connection) -> int:
    """Make the index's ball rows those of the ball files (the truth): rows that differ
    (damaged) are rewritten, rows without a file dropped. The count fixed."""
    on_disk: dict[tuple[str, int], tuple[Any, ...]] = {}
    for path in sorted(d.balls_dir.glob("*/*.json")) if d.balls_dir.is_dir() else []:
        try:
            row = ball_file_row(path)
        except (OSError, ValueError, KeyError, TypeError):
            continue
        on_disk[(row[0], row[1])] = row
    indexed = {
        (r[0], int(r[1])): tuple(r)
        for r in con.execute("SELECT name, version, sha, spec_json, added_at, note FROM balls")
    }
    fixed = 0
    with transaction(con, write=True):
        for key, row in on_disk.items():
            if indexed.get(key) != row:
                con.execute(
                    "INSERT OR REPLACE INTO balls (name, version, sha, spec_json, added_at, "
                    "note) VALUES (?, ?, ?, ?, ?, ?)",
                    row,
                )
                fixed += 1
        for key in indexed.keys() - on_disk.keys():
            con.execute("DELETE FROM balls WHERE name = ? AND version = ?", key)
            fixed += 1
    return fixed


def repair(d: ArchiveDir, *, min_age_s: float = 2.0) -> dict[str, Any]:
    """Verify every segment, the index and the ball rows; quarantine damage. A report: what
    recovery did (:data:`~.maintenance.RECOVERY_COUNTS`), counts, the damaged runs by ID,
    the unreadable segments and the quarantined segments."""
    from .registry import register_segment
    from .segment_file import SegmentFile

    start = time.perf_counter()
    with d.writer_lock():
        report: dict[str, Any] = dict(recover(d, min_age_s=min_age_s))
        con = writer_index(d)
        report["ball_rows_fixed"] = _check_ball_rows(d, con)
        segments = con.execute("SELECT segment_id, path FROM segments").fetchall()
        by_segment: dict[str, list[tuple[str, int]]] = {}
        for rid, seg_id, row in con.execute(
            "SELECT r.run_id, s.segment_id, r.row FROM runs r JOIN segments s ON s.seg = r.seg"
        ):
            by_segment.setdefault(seg_id, []).append((rid, int(row)))
        n_runs = n_fixed = 0
        damaged_runs: list[dict[str, str]] = []
        unreadable: list[dict[str, str]] = []
        quarantined: list[str] = []
        for segment_id, rel in segments:
            path = d.root / rel
            indexed = by_segment.get(segment_id, [])
            try:
                with SegmentFile(path) as seg:
                    ids = seg.run_ids()
                    healthy, bad = seg.verify()
            except (SegmentError, OSError, KeyError) as err:
                reason = _unreadable(err, path)
                damaged = {rid: reason for rid, _ in indexed}
                _quarantine(d, con, segment_id, path, damaged, [])
                damaged_runs += [
                    {"run_id": r, "segment_id": segment_id, "reason": reason} for r in damaged
                ]
                unreadable.append({"segment_id": segment_id, "reason": reason})
                quarantined.append(segment_id)
                continue
            n_runs += len(ids)
            wrong = [(rid, row) for rid, row in indexed if row >= len(ids) or ids[row] != rid]
            if wrong:  # the index disagrees with the file: re-derive this segment's rows
                n_fixed += len(wrong)
                with transaction(con, write=True):
                    con.execute(
                        "DELETE FROM runs WHERE seg = "
                        "(SELECT seg FROM segments WHERE segment_id = ?)",
                        (segment_id,),
                    )
                    con.execute("DELETE FROM segments WHERE segment_id = ?", (segment_id,))
                    dead = con.execute(
                        "SELECT run_id FROM tombstones WHERE segment_id = ?", (segment_id,)
                    ).fetchall()
                    register_segment(con, path, rel, dead=[r[0] for r in dead])
            if bad:
                # removed runs stay removed: neither salvaged nor listed as damaged
                removed = {
                    r[0]
                    for r in con.execute(
                        "SELECT run_id FROM tombstones WHERE segment_id = ?", (segment_id,)
                    )
                }
                healthy = [i for i in healthy if ids[i] not in removed]
                damaged = {
                    ids[i] if i < len(ids) else f"row {i}": why
                    for i, why in bad.items()
                    if i >= len(ids) or ids[i] not in removed
                }
                _quarantine(d, con, segment_id, path, damaged, healthy)
                damaged_runs += [
                    {"run_id": r, "segment_id": segment_id, "reason": why}
                    for r, why in damaged.items()
                ]
                quarantined.append(segment_id)
        # segment files the index cannot list (recovery could not register them; after an
        # index rebuild their runs are unknown): set aside as well
        known = {r[0] for r in con.execute("SELECT segment_id FROM segments")}
        for path in segment_files(d):
            if path.stem in known:
                continue
            try:
                SegmentFile(path).close()
            except (SegmentError, OSError, KeyError) as err:
                reason = _unreadable(err, path)
            else:
                continue  # readable: sealed by a writer since recovery ran, which registers it
            _quarantine(d, con, path.stem, path, {UNKNOWN_RUN: reason}, [])
            unreadable.append({"segment_id": path.stem, "reason": reason})
            quarantined.append(path.stem)
    report.update(
        {
            "segments_checked": len(segments),
            "runs_checked": n_runs,
            "index_rows_fixed": n_fixed,
            "damaged_runs": damaged_runs,
            "unreadable_segments": unreadable,
            "quarantined_segments": quarantined,
            "seconds": round(time.perf_counter() - start, 3),
        }
    )
    return report
