"""The archive's index: one row per live run, one per segment, the ball library, in SQLite.

Table ``runs`` is a rowid table: rows are appended in registration order, and the only index
with random insert positions is the unique run-ID index (created-at and outcome indexes grow at
their ends). The index is derived: everything in it is rebuilt from the segment files, the ball
files and the tombstones (:mod:`bowlrec.archive.rebuild`). Listing or filtering a million
runs reads this file, never the segments. Writers hold the archive's writer lock and commit in
``BEGIN IMMEDIATE`` transactions (rollback journal, ``synchronous=FULL``); readers open the file
read-only (``mode=ro``), so reading needs no write access, and a rebuilt index replaces the old
one by an atomic rename, so a reader sees the old index or the new, never a partial one.
"""

from __future__ import annotations

import contextlib
import math
import os
import sqlite3
import threading
from collections.abc import Iterator, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from bowlrec.errors import IndexQueryError, IndexUnreadableError

__all__ = [
    "COMPARISONS",
    "INDEX_COLUMNS",
    "INDEX_FORMAT",
    "NUMERIC_COLUMNS",
    "PIN_INDEXES",
    "RUN_TABLE_COLUMNS",
    "Filter",
    "IndexQueryError",
    "IndexUnreadableError",
    "create_schema",
    "open_index",
    "cell_text",
    "count_sql",
    "select_sql",
    "transaction",
]

#: the index schema's version (meta key ``index_format``); another value means "rebuild"
INDEX_FORMAT = "3"

#: stored per run (table ``runs``): column -> SQLite type. Compact on purpose (a million rows):
#: the segment and the ball spec's SHA-256 are integer keys into ``segments`` and
#: ``ball_shas``, the creation time is ns since the epoch; listings show them as text
RUN_TABLE_COLUMNS: dict[str, str] = {
    "run_id": "TEXT NOT NULL UNIQUE",
    "seg": "INTEGER NOT NULL",
    "row": "INTEGER NOT NULL",
    "name": "TEXT",
    "created_ns": "INTEGER",
    "ball_name": "TEXT",
    "ball_version": "INTEGER",
    "ball_key": "INTEGER",
    "pattern": "TEXT",
    "outcome": "TEXT",
    "slide_m": "REAL",
    "hook_m": "REAL",
    "pocket_deg": "REAL",
    "time_s": "REAL",
    "x_end_m": "REAL",
    "y_end_m": "REAL",
    "speed_end_mps": "REAL",
    "rev_rate_end_rpm": "REAL",
    "speed_mps": "REAL",
    "rev_rate_rpm": "REAL",
    "mass_kg": "REAL",
    "n_samples": "INTEGER",
    "n_steps": "INTEGER",
    "n_rhs": "INTEGER",
    "n_events": "INTEGER",
    "rtol": "REAL",
    "record": "TEXT",
    "solver": "TEXT",
    "wall_time_s": "REAL",
    "pinfall": "INTEGER",
    "leave": "TEXT",
}

#: a listed run's column (``runs list --json``, ``GET /runs``; the order of the output) -> the
#: SQL expression over ``runs r``, ``segments s`` and ``ball_shas b`` that gives it
_LISTED: dict[str, str] = {
    "run_id": "r.run_id",
    "segment_id": "s.segment_id",
    "row": "r.row",
    "name": "r.name",
    "created_at": "r.created_ns",  # ns in SQL (indexed, sortable); ISO text in the output
    "ball_name": "r.ball_name",
    "ball_version": "r.ball_version",
    "ball_sha": "b.sha",
    **{k: f"r.{k}" for k in list(RUN_TABLE_COLUMNS)[8:]},
    "physics_version": "s.physics_version",
    "bowlrec_version": "s.bowlrec_version",
    "path": "s.path",
}
#: a listed run's column -> its SQLite type
INDEX_COLUMNS: dict[str, str] = {
    k: ("TEXT" if k in ("segment_id", "ball_sha", "created_at") else None)
    or RUN_TABLE_COLUMNS.get(v.removeprefix("r."), "TEXT").split()[0]
    for k, v in _LISTED.items()
}
NUMERIC_COLUMNS = frozenset(k for k, v in INDEX_COLUMNS.items() if v in ("REAL", "INTEGER"))
COMPARISONS = ("<=", ">=", "!=", "=", "<", ">")
#: SELECT list of a listed run (convert ``created_at`` with :func:`listed_row`)
SELECT_COLUMNS = ", ".join(f"{expr} AS {name}" for name, expr in _LISTED.items())
#: FROM clause of a listed run
FROM_RUNS = "runs r JOIN segments s ON s.seg = r.seg LEFT JOIN ball_shas b ON b.key = r.ball_key"


def iso_time(ns: int | None) -> str | None:
    """ISO 8601 UTC with microseconds ("2026-11-24T16:42:11.123456+00:00") of epoch ns."""
    if ns is None:
        return None
    seconds, rest = divmod(int(ns), 1_000_000_000)
    stamp = datetime.fromtimestamp(seconds, UTC).replace(microsecond=rest // 1000)
    return stamp.isoformat(timespec="microseconds")


def cell_text(
    row: Mapping[str, Any], column: str, scale: float = 1.0, fmt: str = "", missing: str = ""
) -> str:
    """A listed run's column as a table shows it: the ball as ``name@version``, the creation
    time to the second, a float times ``scale`` in ``fmt`` (default ``.4g``), ``missing`` for
    a value the run does not have."""
    if column == "ball":
        name = row.get("ball_name")
        return "" if name is None else f"{name}@{row.get('ball_version')}"
    value = row.get(column)
    if value is None:
        return missing
    if column == "created_at":
        return str(value)[:19].replace("T", " ")
    if isinstance(value, float):
        return format(scale * value, fmt or ".4g")
    return str(value)


def listed_row(row: sqlite3.Row) -> dict[str, Any]:
    """A listed run as a dict, its creation time as ISO text."""
    out = dict(row)
    out["created_at"] = iso_time(out["created_at"])
    return out


#: partial indexes of the pins' columns: they hold runs with pins only, so runs without cost
#: nothing
PIN_INDEXES = (
    "CREATE INDEX IF NOT EXISTS runs_leave ON runs (leave, created_ns) WHERE leave IS NOT NULL",
    "CREATE INDEX IF NOT EXISTS runs_pinfall ON runs (pinfall, created_ns) "
    "WHERE pinfall IS NOT NULL",
)
_PIN_INDEX_SQL = ";\n".join(PIN_INDEXES)

_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs (
    seq INTEGER PRIMARY KEY,
    {", ".join(f"{k} {v}" for k, v in RUN_TABLE_COLUMNS.items())}
);
CREATE INDEX IF NOT EXISTS runs_created ON runs (created_ns);
CREATE INDEX IF NOT EXISTS runs_outcome ON runs (outcome, created_ns);
{_PIN_INDEX_SQL};
CREATE TABLE IF NOT EXISTS segments (
    seg INTEGER PRIMARY KEY,
    segment_id TEXT NOT NULL UNIQUE,
    path TEXT NOT NULL,
    n_runs INTEGER NOT NULL,
    size_bytes INTEGER NOT NULL,
    bowlrec_version TEXT,
    physics_version TEXT,
    provenance_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS ball_shas (key INTEGER PRIMARY KEY, sha TEXT NOT NULL UNIQUE);
CREATE TABLE IF NOT EXISTS shadowed (
    segment_id TEXT NOT NULL,
    run_id TEXT NOT NULL,
    row INTEGER NOT NULL,
    PRIMARY KEY (segment_id, run_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS tombstones (
    segment_id TEXT NOT NULL,
    run_id TEXT NOT NULL,
    reason TEXT NOT NULL,
    PRIMARY KEY (segment_id, run_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS tombstone_files (name TEXT PRIMARY KEY) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS damaged (
    segment_id TEXT NOT NULL,
    run_id TEXT NOT NULL,
    reason TEXT NOT NULL,
    detected_at TEXT NOT NULL,
    PRIMARY KEY (segment_id, run_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS balls (
    name TEXT NOT NULL,
    version INTEGER NOT NULL,
    sha TEXT NOT NULL,
    spec_json TEXT NOT NULL,
    added_at TEXT NOT NULL,
    note TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (name, version)
);
CREATE INDEX IF NOT EXISTS balls_sha ON balls (sha);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


def create_schema(con: sqlite3.Connection) -> None:
    """Create the tables (a no-op where they exist) and stamp the index format."""
    con.executescript(_SCHEMA)
    con.execute(
        "INSERT OR REPLACE INTO meta (key, value) VALUES ('index_format', ?)", (INDEX_FORMAT,)
    )


def _configure(con: sqlite3.Connection) -> None:
    con.row_factory = sqlite3.Row
    con.execute("PRAGMA journal_mode=DELETE")
    con.execute("PRAGMA synchronous=FULL")
    # 64 MiB of page cache (SQLite's default is 2 MiB): registering a segment inserts its run
    # IDs at random places of the unique run-ID index, whose pages then stay cached between
    # registrations instead of being read again
    con.execute("PRAGMA cache_size=-65536")


def check_format(con: sqlite3.Connection) -> None:
    """Raise :class:`IndexUnreadableError` unless this is an index of :data:`INDEX_FORMAT`."""
    try:
        rows = con.execute("SELECT value FROM meta WHERE key = 'index_format'").fetchall()
        row = rows[0] if rows else None
    except sqlite3.DatabaseError as err:
        raise IndexUnreadableError(f"not a bowlrec index ({err})") from None
    if row is None or row[0] != INDEX_FORMAT:
        found = None if row is None else row[0]
        raise IndexUnreadableError(f"index format {found!r}, expected {INDEX_FORMAT!r}")


_local = threading.local()


def open_index(path: Path, *, write: bool) -> sqlite3.Connection:
    """A connection to the index at ``path`` (kept per thread, reopened when the file was
    replaced). ``write=False`` opens read-only (``mode=ro``): no write access needed.

    Raises :class:`IndexUnreadableError` when the file is missing, not a database or of
    another index format.
    """
    cache: dict[tuple[str, bool], tuple[int, sqlite3.Connection]] = _local.__dict__.setdefault(
        "connections", {}
    )
    key = (str(path), write)
    try:
        inode = os.stat(path).st_ino
    except FileNotFoundError:
        raise IndexUnreadableError(f"{path}: no index file") from None
    cached = cache.get(key)
    if cached is not None and cached[0] == inode:
        try:  # the file may have been damaged, or left with a hot journal, since it was opened
            check_format(cached[1])
            return cached[1]
        except IndexUnreadableError:
            pass  # closed and reopened below
    if cached is not None:
        cached[1].close()
        del cache[key]
    uri = f"file:{path}?mode={'rw' if write else 'ro'}"
    try:
        con = sqlite3.connect(uri, uri=True, timeout=60.0, isolation_level=None)
    except sqlite3.OperationalError as err:
        raise IndexUnreadableError(f"{path}: cannot open the index ({err})") from None
    try:
        con.row_factory = sqlite3.Row
        if write:
            _configure(con)
        check_format(con)
    except (sqlite3.DatabaseError, IndexUnreadableError) as err:
        con.close()
        raise IndexUnreadableError(f"{path}: {err}") from None
    cache[key] = (inode, con)
    return con


def forget_connections(path: Path) -> None:
    """Close this thread's cached connections to ``path`` (before the file is replaced)."""
    cache = _local.__dict__.get("connections", {})
    for key in [k for k in cache if k[0] == str(path)]:
        cache.pop(key)[1].close()


def new_index(path: Path) -> sqlite3.Connection:
    """A fresh index file at ``path`` (which must not exist), schema in place."""
    con = sqlite3.connect(path, timeout=60.0, isolation_level=None)
    _configure(con)
    create_schema(con)
    return con


@contextlib.contextmanager
def transaction(con: sqlite3.Connection, *, write: bool = False) -> Iterator[sqlite3.Connection]:
    """One transaction: ``BEGIN IMMEDIATE`` for writers (takes the write lock up front, so a
    read-then-write never fails with "database is locked"), a consistent snapshot for readers."""
    con.execute("BEGIN IMMEDIATE" if write else "BEGIN")
    try:
        yield con
    except BaseException:
        con.execute("ROLLBACK")
        raise
    con.execute("COMMIT")


class Filter:
    """A parsed ``column op value`` condition, e.g. ``hook_m>=0.1`` or ``outcome=pins``."""

    def __init__(self, column: str, op: str, value: Any) -> None:
        if column not in INDEX_COLUMNS:
            raise IndexQueryError(
                f"unknown column {column!r} in filter; columns: {', '.join(INDEX_COLUMNS)}"
            )
        if op not in COMPARISONS:
            raise IndexQueryError(f"unknown comparison {op!r}; use one of {' '.join(COMPARISONS)}")
        if column == "created_at":
            value = _epoch_ns(value)
        if column in NUMERIC_COLUMNS and not isinstance(value, int | float):
            try:
                number = float(value)
            except (TypeError, ValueError):
                number = math.nan
            if not math.isfinite(number):
                raise IndexQueryError(
                    f"filter {column}{op}{value!r}: {column} is numeric, {value!r} is not a "
                    "finite number"
                ) from None
            value = number
        self.column, self.op, self.value = column, op, value

    @classmethod
    def parse(cls, text: str) -> Filter:
        """Parse ``column<op>value`` (ops: <= >= != = < >); whitespace around parts is ignored
        and a value in matching quotes (``physics_version='frohlich2004-ts54-7'``) is taken
        without them."""
        for op in COMPARISONS:  # two-character operators are tried first
            if op in text:
                column, value = text.split(op, 1)
                value = value.strip()
                if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"":
                    value = value[1:-1]  # a quoted value, as SQL and shells write one
                return cls(column.strip(), op, value)
        raise IndexQueryError(
            f"cannot parse filter {text!r}: expected column<op>value with op in "
            f"{' '.join(COMPARISONS)}, e.g. hook_m>=0.1"
        )

    def sql(self) -> tuple[str, Any]:
        return f"{_LISTED[self.column]} {self.op} ?", self.value

    def __repr__(self) -> str:
        return f"Filter({self.column}{self.op}{self.value!r})"


def _epoch_ns(value: Any) -> int:
    """A creation-time filter value (ISO 8601 text, naive = UTC) as ns since the epoch."""
    try:
        stamp = datetime.fromisoformat(str(value))
    except ValueError:
        raise IndexQueryError(
            f"filter created_at: {value!r} is not an ISO 8601 time (e.g. 2026-11-24T16:00:00)"
        ) from None
    if stamp.tzinfo is None:
        stamp = stamp.replace(tzinfo=UTC)
    delta = stamp - datetime(1970, 1, 1, tzinfo=UTC)
    return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


def select_sql(
    filters: Sequence[Filter],
    order_by: str,
    limit: int | None,
    clauses: Sequence[tuple[str, Sequence[Any]]] = (),
    offset: int = 0,
) -> tuple[str, list[Any]]:
    """The SELECT statement and its parameters for :meth:`Archive.list_runs`.

    ``clauses`` are extra (sql, params) conditions ANDed with the filters; ``offset``: rows of
    the ordered result skipped first. Rows that tie on the sort column come in the order they
    were indexed (the same direction as the sort), so an index on the sort column (creation
    time, outcome) gives the whole order.

    A page (``limit``) whose filters and order read only table ``runs`` is selected by run
    first and joined after (a deferred join): the rows skipped by ``offset`` are read from the
    index alone, so the last page of a million runs costs about what the first does
    (``benchmarks/results/web.md``).
    """
    column = order_by.removeprefix("-")
    if column not in INDEX_COLUMNS:
        raise IndexQueryError(f"cannot order by unknown column {order_by!r}")
    direction = "DESC" if order_by.startswith("-") else "ASC"
    order = f" ORDER BY {_LISTED[column]} {direction}, r.seq {direction}"
    page = ""
    if limit is not None or offset:
        page = f" LIMIT {-1 if limit is None else int(limit)}"
    if offset:
        page += f" OFFSET {int(offset)}"
    only_runs = not clauses and all(_LISTED[c].startswith("r.") for c in _columns(filters, column))
    if page and only_runs:
        where, params = _where_sql(filters, ())
        inner = f"SELECT r.seq FROM runs r{where}{order}{page}"
        sql = f"SELECT {SELECT_COLUMNS} FROM {FROM_RUNS} WHERE r.seq IN ({inner}){order}"
        return sql, params
    where, params = _where_sql(filters, clauses)
    return f"SELECT {SELECT_COLUMNS} FROM {FROM_RUNS}{where}{order}{page}", params


def _columns(filters: Sequence[Filter], order_column: str) -> list[str]:
    """The listed columns a query reads: its filters' and its order's."""
    return [f.column for f in filters] + [order_column]


def count_sql(
    filters: Sequence[Filter],
    clauses: Sequence[tuple[str, Sequence[Any]]] = (),
    cap: int | None = None,
) -> tuple[str, list[Any]]:
    """The statement counting the runs :func:`select_sql` would list (at most ``cap``: a
    count stops there, so that counting a broad filter of a million runs stays cheap)."""
    where, params = _where_sql(filters, clauses)
    inner = f"SELECT 1 FROM {FROM_RUNS}{where}"
    if cap is not None:
        inner += f" LIMIT {int(cap)}"
    return f"SELECT COUNT(*) FROM ({inner})", params


def _where_sql(
    filters: Sequence[Filter], clauses: Sequence[tuple[str, Sequence[Any]]]
) -> tuple[str, list[Any]]:
    params: list[Any] = [p for _, ps in clauses for p in ps]
    clauses_sql = [f"({c})" for c, _ in clauses]
    for f in filters:
        clause, value = f.sql()
        clauses_sql.append(clause)
        params.append(value)
    return (f" WHERE {' AND '.join(clauses_sql)}" if clauses_sql else ""), params
