"""``runs repair``: every stored run's digest checked, the index held against the segments, and
damaged segments quarantined without taking their healthy runs with them.

For a segment with damaged runs, in this order (a kill at any point loses nothing healthy):
1. its healthy runs are rewritten into a new sealed segment (same provenance);
2. the damaged file moves to ``quarantine/`` with a JSON report naming each damaged run;
3. one index transaction drops the old segment, registers the new one, lists the damaged runs
   (``runs list --damaged``) and serves a damaged run from a duplicate copy where one exists.
"""

from __future__ import annotations

import json
import os
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.atomic_files import atomic_path, fsync_dir
from bowlrec.errors import SegmentError

from .index import transaction
from .maintenance import promote_copies, recover
from .quarantine import QUARANTINE_FORMAT
from .registry import register_segment
from .segment import SegmentBuilder
from .segment_file import SegmentFile

if TYPE_CHECKING:
    import sqlite3

    from .store import Archive

__all__ = ["repair"]


def _provenance(seg: SegmentFile) -> dict[str, Any]:
    skip = {"format", "format_version", "segment_id", "n_runs"}
    return {k: v for k, v in seg.provenance.items() if k not in skip}


def _quarantine(
    archive: Archive,
    con: sqlite3.Connection,
    segment_id: str,
    path: Path,
    damaged: dict[str, str],
    healthy_rows: list[int],
) -> dict[str, Any]:
    """Rewrite the healthy runs, move the file aside, fix the index (see the module doc)."""
    salvaged = None
    if healthy_rows:
        with SegmentFile(path) as seg:
            builder = SegmentBuilder(_provenance(seg))
            for rec in seg.read_all(healthy_rows):
                builder.append(rec.to_record())
        salvaged = archive.seal(builder)
    archive.quarantine_dir.mkdir(exist_ok=True)
    at = datetime.now(UTC).isoformat(timespec="seconds")
    report = {
        "format": QUARANTINE_FORMAT,
        "segment_id": segment_id,
        "at": at,
        "damaged": [{"run_id": rid, "reason": why} for rid, why in sorted(damaged.items())],
        "salvaged_into": None if salvaged is None else salvaged.segment_id,
        "salvaged_runs": len(healthy_rows),
    }
    with atomic_path(archive.quarantine_dir / f"{segment_id}.json") as tmp:
        tmp.write_text(json.dumps(report, indent=1) + "\n")
    if path.exists():
        os.replace(path, archive.quarantine_dir / path.name)
        fsync_dir(archive.segments_dir)
    with transaction(con, write=True):
        con.execute(
            "DELETE FROM runs WHERE seg = (SELECT seg FROM segments WHERE segment_id = ?)",
            (segment_id,),
        )
        con.execute("DELETE FROM shadowed WHERE segment_id = ?", (segment_id,))
        con.execute("DELETE FROM segments WHERE segment_id = ?", (segment_id,))
        if salvaged is not None:
            register_segment(con, salvaged.path, str(salvaged.path.relative_to(archive.root)))
        for rid, why in damaged.items():
            con.execute(
                "INSERT OR REPLACE INTO damaged (segment_id, run_id, reason, detected_at) "
                "VALUES (?, ?, ?, ?)",
                (segment_id, rid, why, at),
            )
        promote_copies(archive, con, damaged)
        con.execute("DELETE FROM damaged WHERE run_id IN (SELECT run_id FROM runs)")
    return report


def repair(archive: Archive, *, min_age_s: float = 2.0) -> dict[str, Any]:
    """Verify every segment and the index; quarantine damage. Returns a report (counts, the
    damaged runs by ID and the quarantined segments)."""
    start = time.perf_counter()
    with archive.writer_lock():
        con = archive.index_writer()
        report: dict[str, Any] = dict(recover(archive, con, min_age_s=min_age_s))
        segments = con.execute("SELECT segment_id, path FROM segments").fetchall()
        by_segment: dict[str, list[tuple[str, int]]] = {}
        for rid, seg_id, row in con.execute(
            "SELECT r.run_id, s.segment_id, r.row FROM runs r JOIN segments s ON s.seg = r.seg"
        ):
            by_segment.setdefault(seg_id, []).append((rid, int(row)))
        n_runs = n_fixed = 0
        damaged_runs: list[dict[str, str]] = []
        quarantined: list[str] = []
        for segment_id, rel in segments:
            path = archive.root / rel
            indexed = by_segment.get(segment_id, [])
            try:
                with SegmentFile(path) as seg:
                    ids = seg.run_ids()
                    healthy, bad = seg.verify()
            except (SegmentError, OSError, KeyError) as err:
                reason = "segment file missing" if not path.exists() else f"unreadable: {err}"
                damaged = {rid: reason for rid, _ in indexed}
                _quarantine(archive, con, segment_id, path, damaged, [])
                damaged_runs += [
                    {"run_id": r, "segment_id": segment_id, "reason": reason} for r in damaged
                ]
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
                _quarantine(archive, con, segment_id, path, damaged, healthy)
                damaged_runs += [
                    {"run_id": r, "segment_id": segment_id, "reason": why}
                    for r, why in damaged.items()
                ]
                quarantined.append(segment_id)
    report.update(
        {
            "segments_checked": len(segments),
            "runs_checked": n_runs,
            "index_rows_fixed": n_fixed,
            "damaged_runs": damaged_runs,
            "quarantined_segments": quarantined,
            "seconds": round(time.perf_counter() - start, 3),
        }
    )
    return report
