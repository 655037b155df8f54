"""Questions the index answers, read-only: runs listed and counted with filters, a run ID
resolved and located, index rows, damaged copies, the archive's counts and sizes.

Every function reads through :func:`~.rebuild.read_index`: the index file opened read-only,
or an index built in memory while the file is missing or unreadable. None writes.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from bowlrec.core.codes import OUTCOMES
from bowlrec.errors import InputError, RunNotFoundError

from .ball_files import parse_ball_ref
from .directory import ArchiveDir, read_marker
from .index import FROM_RUNS, SELECT_COLUMNS, Filter, count_sql, listed_row, select_sql
from .rebuild import read_index

__all__ = [
    "count",
    "count_runs",
    "damaged",
    "info",
    "list_runs",
    "locate",
    "resolve_id",
    "rows",
    "run_filters",
]


def run_filters(
    d: ArchiveDir,
    ball: str | None = None,
    pattern: str | None = None,
    outcome: str | None = None,
    name: str | None = None,
    where: Sequence[Filter | str] = (),
    *,
    leave: str | None = None,
    pinfall: int | None = None,
    strikes: bool = False,
) -> tuple[list[Filter], list[tuple[str, list[Any]]]]:
    """The filters and extra SQL clauses of :func:`list_runs`' arguments: ``leave`` the
    leave's name as stored ("strike", "10", ...), ``pinfall`` pins down, ``strikes`` strikes
    only (runs without pins have neither and match none of them)."""
    if outcome is not None and outcome not in OUTCOMES.values():
        raise InputError(
            f"outcome {outcome!r} is not an outcome; the outcomes are "
            + ", ".join(OUTCOMES.values())
            + " ('pins': the ball reached the pins)"
        )
    if isinstance(where, str | Filter):  # one condition rather than a list of them
        where = [where]
    filters = [w if isinstance(w, Filter) else Filter.parse(w) for w in where]
    clauses = [] if ball is None else [_ball_clause(d, ball)]
    if strikes:
        if leave is not None and leave != "strike":
            raise InputError(f"strikes only and leave {leave!r} exclude each other")
        leave = "strike"
    for column, value in (
        ("pattern", pattern),
        ("outcome", outcome),
        ("name", name),
        ("leave", leave),
        ("pinfall", pinfall),
    ):
        if value is not None:
            filters.append(Filter(column, "=", value))
    return filters, clauses


def _ball_clause(d: ArchiveDir, ball: str) -> tuple[str, list[Any]]:
    """Runs that used library ball ``name`` (any version) or ``name@version``: by the
    reference stored with the run, or by an identical spec (runs made before the ball was
    added to the library)."""
    bname, bversion = parse_ball_ref(ball)
    sql = "SELECT sha FROM balls WHERE name = ?"
    params: tuple[Any, ...] = (bname,)
    if bversion is not None:
        sql, params = sql + " AND version = ?", (bname, bversion)
    shas = [r[0] for r in read_index(d).execute(sql + " ORDER BY version", params)]
    by_ref = "r.ball_name = ?" + ("" if bversion is None else " AND r.ball_version = ?")
    out: list[Any] = [bname] + ([] if bversion is None else [bversion])
    if shas:
        by_ref += f" OR b.sha IN ({', '.join('?' for _ in shas)})"
        out += shas
    return by_ref, out


def list_runs(
    d: ArchiveDir,
    filters: Sequence[Filter],
    clauses: Sequence[tuple[str, list[Any]]] = (),
    *,
    order_by: str = "created_at",
    limit: int | None = None,
    offset: int = 0,
) -> list[dict[str, Any]]:
    """Listed runs (dicts keyed by :data:`~.index.INDEX_COLUMNS`) matching ``filters`` and
    ``clauses`` (:func:`run_filters`), ordered, paged."""
    sql, params = select_sql(filters, order_by, limit, clauses, offset=offset)
    # one SELECT reads one consistent snapshot (and the in-memory index of a process that
    # may not write is shared by its threads: no transaction is opened on it)
    return [listed_row(r) for r in read_index(d).execute(sql, params)]


def count_runs(
    d: ArchiveDir,
    filters: Sequence[Filter],
    clauses: Sequence[tuple[str, list[Any]]] = (),
    cap: int | None = None,
) -> int:
    """How many runs :func:`list_runs` lists with these filters, counting at most ``cap``."""
    sql, params = count_sql(filters, clauses, cap)
    return int(read_index(d).execute(sql, params).fetchone()[0])


def damaged(d: ArchiveDir) -> list[dict[str, Any]]:
    """Copies of runs found damaged (set aside; quarantined by ``runs repair``), oldest
    first; run ID "?" for an unreadable segment whose runs are not known."""
    rows = read_index(d).execute(
        "SELECT run_id, segment_id, reason, detected_at FROM damaged ORDER BY detected_at"
    )
    return [dict(r) for r in rows]


def resolve_id(d: ArchiveDir, run_id: str) -> str:
    """The full run ID for an ID or a unique prefix of at least 4 characters."""
    if len(run_id) < 4 or not all(c in "0123456789abcdef" for c in run_id):
        raise RunNotFoundError(f"{run_id!r} is not a run ID (hex, at least 4 characters)")
    found = (
        read_index(d)
        .execute(
            "SELECT run_id FROM runs WHERE run_id >= ? AND run_id < ? LIMIT 2",
            (run_id, run_id + "g"),
        )
        .fetchall()
    )
    if not found:
        raise RunNotFoundError(f"no run {run_id!r} in archive {d.root}")
    if len(found) > 1:
        raise RunNotFoundError(f"run ID prefix {run_id!r} is ambiguous; give more characters")
    return str(found[0][0])


def locate(d: ArchiveDir, run_id: str) -> tuple[str, int, Path] | None:
    """(segment ID, row, segment path) of an archived run ID; None when not archived."""
    found = (
        read_index(d)
        .execute(
            "SELECT s.segment_id, r.row, s.path FROM runs r "
            "JOIN segments s ON s.seg = r.seg WHERE r.run_id = ?",
            (run_id,),
        )
        .fetchall()
    )
    return None if not found else (found[0][0], int(found[0][1]), d.root / found[0][2])


def rows(d: ArchiveDir, run_ids: Iterable[str]) -> dict[str, dict[str, Any]]:
    """Index rows of the archived runs among ``run_ids`` (full IDs), by run ID."""
    ids = list(run_ids)
    out: dict[str, dict[str, Any]] = {}
    con = read_index(d)
    for i in range(0, len(ids), 900):
        part = ids[i : i + 900]
        marks = ", ".join("?" for _ in part)
        sql = f"SELECT {SELECT_COLUMNS} FROM {FROM_RUNS} WHERE r.run_id IN ({marks})"
        out.update({r["run_id"]: listed_row(r) for r in con.execute(sql, part)})
    return out


def count(d: ArchiveDir) -> int:
    """The number of live runs."""
    return int(read_index(d).execute("SELECT COUNT(*) FROM runs").fetchall()[0][0])


def info(d: ArchiveDir) -> dict[str, Any]:
    """Format, counts and sizes on disk (bytes) of the archive's parts."""
    con = read_index(d)

    def rows_of(table: str) -> int:
        return int(con.execute(f"SELECT COUNT(*) FROM {table}").fetchall()[0][0])

    seg_bytes = con.execute("SELECT COALESCE(SUM(size_bytes), 0) FROM segments").fetchall()
    index_bytes = d.index_path.stat().st_size if d.index_path.exists() else 0
    return {
        "archive": str(d.root),
        "format_version": read_marker(d.marker).get("format_version"),
        "runs": rows_of("runs"),
        "segments": rows_of("segments"),
        "segment_bytes": int(seg_bytes[0][0]),
        "index_bytes": index_bytes,
        "balls": rows_of("balls"),
        "removed_or_damaged_copies": rows_of("tombstones"),
        "duplicate_copies": rows_of("shadowed"),
        "damaged_runs": rows_of("damaged"),
    }
