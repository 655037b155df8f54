"""Registering sealed segments in the index: their runs become index rows in one transaction.

The first copy of a run ID to be registered is the live one; later copies of the same ID (two
writers that simulated the same scene at once) are recorded as ``shadowed`` and dropped by
compaction. Copies a tombstone names are skipped. Registering a segment twice is a no-op.
"""

from __future__ import annotations

import json
import operator
import sqlite3
from collections.abc import Iterable, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from .index import RUN_TABLE_COLUMNS
from .segment_file import SegmentFile
from .segment_format import SUMMARY_FLOAT_COLUMNS, SUMMARY_INT_COLUMNS, SegmentInfo

__all__ = [
    "INSERT_RUN",
    "ball_keys",
    "index_rows",
    "insert_runs",
    "register_segment",
    "segment_key",
    "segment_row",
]

INSERT_RUN = (
    f"INSERT INTO runs ({', '.join(RUN_TABLE_COLUMNS)}) "
    f"VALUES ({', '.join('?' for _ in RUN_TABLE_COLUMNS)})"
)


@cache
def _insert_sql(absent: frozenset[int]) -> str:
    """INSERT_RUN with NULL in place of the parameters at positions ``absent``."""
    values = ", ".join("NULL" if k in absent else "?" for k in range(len(RUN_TABLE_COLUMNS)))
    return f"INSERT INTO runs ({', '.join(RUN_TABLE_COLUMNS)}) VALUES ({values})"


def insert_runs(con: sqlite3.Connection, rows: Sequence[tuple[Any, ...]]) -> None:
    """Insert ``rows`` (:func:`index_rows`) into table ``runs``. A column no row has (the
    pins' columns of runs without pins, the ball of runs without a library reference) is NULL
    in the statement rather than bound row by row: Python's sqlite3 binds None through its
    adapter lookup, which costs ~0.8 µs a value, a quarter of a summary run's insert."""
    if not rows:
        return
    absent = frozenset(
        k for k, v in enumerate(rows[0]) if v is None and all(r[k] is None for r in rows)
    )
    if not absent:
        con.executemany(INSERT_RUN, rows)
        return
    keep = [k for k in range(len(RUN_TABLE_COLUMNS)) if k not in absent]
    pick = operator.itemgetter(*keep)
    con.executemany(_insert_sql(absent), (pick(r) for r in rows))


def _texts(arr: Any) -> list[str]:
    n = int(arr.shape[0])
    if n and bool((arr == arr[0]).all()):  # a column a batch's segment shares (name, pattern)
        return [bytes(arr[0]).decode()] * n
    return [b.decode() for b in arr.tolist()]


def _floats(arr: Any) -> list[float | None]:
    values: list[float | None] = arr.tolist()
    if not np.isnan(arr).any():
        return values
    return [None if v != v else v for v in values]  # NaN stands for None


def _ball_parts(refs: list[str]) -> tuple[list[str | None], list[int | None]]:
    cache: dict[str, tuple[str | None, int | None]] = {}
    for ref in set(refs):
        name, _, version = ref.rpartition("@")
        cache[ref] = (name, int(version)) if name and version.isdigit() else (None, None)
    return [cache[r][0] for r in refs], [cache[r][1] for r in refs]


def ball_keys(con: sqlite3.Connection, shas: list[str]) -> list[int]:
    """The ``ball_shas`` keys of ball-spec SHA-256s (new ones are added)."""
    unique = sorted(set(shas))
    con.executemany("INSERT OR IGNORE INTO ball_shas (sha) VALUES (?)", [(x,) for x in unique])
    keys: dict[str, int] = {}
    for i in range(0, len(unique), 900):
        part = unique[i : i + 900]
        marks = ", ".join("?" for _ in part)
        keys.update(con.execute(f"SELECT sha, key FROM ball_shas WHERE sha IN ({marks})", part))
    return [keys[x] for x in shas]


def index_rows(con: sqlite3.Connection, seg: int, cols: dict[str, Any]) -> list[tuple[Any, ...]]:
    """Rows of table ``runs`` (columns in :data:`RUN_TABLE_COLUMNS` order) from a segment's
    index columns (:meth:`SegmentFile.index_columns`); ``seg`` is the segment's key."""
    n = int(cols["run_id"].shape[0])
    ball_name, ball_version = _ball_parts(_texts(cols["ball_ref"]))
    values: dict[str, list[Any]] = {
        "run_id": _texts(cols["run_id"]),
        "seg": [seg] * n,
        "row": list(range(n)),
        "name": _texts(cols["name"]),
        "created_ns": cols["created_at_ns"].tolist(),
        "ball_name": ball_name,
        "ball_version": ball_version,
        "ball_key": ball_keys(con, _texts(cols["ball_sha"])),
        "pattern": _texts(cols["pattern"]),
        "outcome": _texts(cols["outcome"]),
        "n_samples": cols["n_samples"].tolist(),
        "record": _texts(cols["record"]),
        "solver": _texts(cols["solver"]),
    }
    for name in (*SUMMARY_FLOAT_COLUMNS, "speed_mps", "rev_rate_rpm", "mass_kg", "rtol"):
        values[name] = _floats(cols[name])
    values["wall_time_s"] = cols["wall_time_s"].tolist()
    for name in SUMMARY_INT_COLUMNS:
        values[name] = cols[name].tolist()
    for name in ("pinfall", "leave"):  # format 2.2; None for a run without pins
        values[name] = cols[name].tolist() if name in cols else [None] * n
    return list(zip(*(values[k] for k in RUN_TABLE_COLUMNS), strict=True))


def segment_key(con: sqlite3.Connection, segment_id: str) -> int | None:
    """The integer key of a registered segment (None when it is not registered)."""
    rows = con.execute("SELECT seg FROM segments WHERE segment_id = ?", (segment_id,)).fetchall()
    return int(rows[0][0]) if rows else None


def segment_row(
    segment_id: str, provenance: dict[str, Any], n_runs: int, rel_path: str, size_bytes: int
) -> tuple[Any, ...]:
    """The ``segments`` table row of a segment (its key aside)."""
    skip = ("format", "format_version", "segment_id", "n_runs")  # not shared by other segments
    prov = {
        k: v
        for k, v in provenance.items()
        if k not in skip and isinstance(v, str | int | float | bool)
    }
    return (
        segment_id,
        rel_path,
        n_runs,
        size_bytes,
        prov.get("bowlrec_version"),
        prov.get("physics_version"),
        json.dumps(prov, sort_keys=True),
    )


def _already_registered(con: sqlite3.Connection, key: int, segment_id: str) -> tuple[int, int]:
    live = con.execute("SELECT COUNT(*) FROM runs WHERE seg = ?", (key,)).fetchall()
    shadowed = con.execute(
        "SELECT COUNT(*) FROM shadowed WHERE segment_id = ?", (segment_id,)
    ).fetchall()
    return int(live[0][0]), int(shadowed[0][0])


def register_segment(
    con: sqlite3.Connection,
    path: Path,
    rel_path: str,
    *,
    dead: Iterable[str] = (),
    info: SegmentInfo | None = None,
) -> tuple[int, int]:
    """Index the runs of the segment at ``path`` (inside the caller's write transaction).

    ``dead``: run IDs of this segment that a tombstone names (skipped); ``info``: the
    :class:`SegmentInfo` of a segment sealed in this process (its columns are used instead of
    reading the file back). Returns (runs now indexed, copies shadowed by an already indexed
    run). Raises SegmentError for a file that is not a readable segment.
    """
    if info is not None and info.index_columns is not None and info.provenance is not None:
        segment_id, provenance = info.segment_id, info.provenance
        columns, n_runs = info.index_columns, len(info.run_ids)
    else:
        with SegmentFile(path) as seg:
            segment_id, provenance = seg.segment_id, seg.provenance
            columns, n_runs = seg.index_columns(), seg.n_runs
    known = segment_key(con, segment_id)
    if known is not None:  # registered already (by a recovery in this or another process)
        return _already_registered(con, known, segment_id)
    cur = con.execute(
        "INSERT INTO segments (segment_id, path, n_runs, size_bytes, bowlrec_version, "
        "physics_version, provenance_json) VALUES (?, ?, ?, ?, ?, ?, ?)",
        segment_row(segment_id, provenance, n_runs, rel_path, path.stat().st_size),
    )
    rows = index_rows(con, int(cur.lastrowid or 0), columns)
    dead_ids = set(dead)
    if dead_ids:
        rows = [r for r in rows if r[0] not in dead_ids]
    # the common case first: no run of the segment is indexed yet, so the rows go in as they
    # are (the unique run-ID index checks that); only when one is indexed already (a duplicate
    # copy) are the rows split into fresh and shadowed
    con.execute("SAVEPOINT register_runs")
    try:
        insert_runs(con, rows)
    except sqlite3.IntegrityError:
        con.execute("ROLLBACK TO register_runs")
    else:
        con.execute("RELEASE register_runs")
        return len(rows), 0
    con.execute("RELEASE register_runs")
    existing: set[str] = set()
    ids = [r[0] for r in rows]
    for i in range(0, len(ids), 900):  # SQLite's default limit on bound parameters is 999
        part = ids[i : i + 900]
        marks = ", ".join("?" for _ in part)
        existing.update(
            r[0] for r in con.execute(f"SELECT run_id FROM runs WHERE run_id IN ({marks})", part)
        )
    fresh = [r for r in rows if r[0] not in existing]
    insert_runs(con, fresh)
    con.executemany(
        "INSERT OR IGNORE INTO shadowed (segment_id, run_id, row) VALUES (?, ?, ?)",
        [(segment_id, r[0], r[2]) for r in rows if r[0] in existing],
    )
    return len(fresh), len(rows) - len(fresh)
