"""The archive's index: one row per run (summary metrics, ball, pattern), in SQLite.

Listing or filtering 10,000 runs reads this one table, never the run files. SQLite gives atomic
transactions (a killed writer leaves the last committed state), concurrent readers and indexed
queries from the standard library. The run files stay the source of truth: the index can be
rebuilt from them (:meth:`bowlrec.archive.Archive.reindex`).
"""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "COMPARISONS",
    "INDEX_COLUMNS",
    "NUMERIC_COLUMNS",
    "Filter",
    "IndexError_",
    "connect",
]

#: column name -> SQLite type; the order is the order of ``runs list`` output
INDEX_COLUMNS: dict[str, str] = {
    "run_id": "TEXT PRIMARY KEY",
    "name": "TEXT",
    "created_at": "TEXT",
    "ball_name": "TEXT",
    "ball_version": "INTEGER",
    "ball_sha": "TEXT",
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
    "physics_version": "TEXT",
    "bowlrec_version": "TEXT",
    "path": "TEXT",
}
NUMERIC_COLUMNS = frozenset(k for k, v in INDEX_COLUMNS.items() if v in ("REAL", "INTEGER"))
COMPARISONS = ("<=", ">=", "!=", "=", "<", ">")

_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs ({", ".join(f"{k} {v}" for k, v in INDEX_COLUMNS.items())});
CREATE INDEX IF NOT EXISTS runs_ball ON runs (ball_name, ball_version);
CREATE INDEX IF NOT EXISTS runs_pattern ON runs (pattern);
CREATE INDEX IF NOT EXISTS runs_outcome ON runs (outcome);
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


class IndexError_(ValueError):  # noqa: N801 - "IndexError" is a builtin
    """A bad query on the index (unknown column, bad comparison or value)."""


@contextlib.contextmanager
def connect(path: Path) -> Iterator[sqlite3.Connection]:
    """A connection with the schema in place; commits on success, rolls back on error.

    WAL journaling with synchronous=FULL: a committed row survives a killed process (and a power
    loss); readers never block the writer. One connection per call keeps threads independent.
    """
    con = sqlite3.connect(path, timeout=60.0, isolation_level=None)
    try:
        con.row_factory = sqlite3.Row
        con.execute("PRAGMA journal_mode=WAL")
        con.execute("PRAGMA synchronous=FULL")
        con.executescript(_SCHEMA)
        con.execute("BEGIN")
        try:
            yield con
        except BaseException:
            con.execute("ROLLBACK")
            raise
        con.execute("COMMIT")
    finally:
        con.close()


class Filter:
    """A parsed ``column op value`` condition, e.g. ``hook_m>=0.1`` or ``outcome=pins``."""

    def __init__(self, column: str, op: str, value: Any) -> None:
        if column not in INDEX_COLUMNS:
            raise IndexError_(
                f"unknown column {column!r} in filter; columns: {', '.join(INDEX_COLUMNS)}"
            )
        if op not in COMPARISONS:
            raise IndexError_(f"unknown comparison {op!r}; use one of {' '.join(COMPARISONS)}")
        if column in NUMERIC_COLUMNS and not isinstance(value, int | float):
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise IndexError_(
                    f"filter {column}{op}{value!r}: {column} is numeric, {value!r} is not a number"
                ) from None
        self.column, self.op, self.value = column, op, value

    @classmethod
    def parse(cls, text: str) -> Filter:
        """Parse ``column<op>value`` (ops: <= >= != = < >); whitespace around parts is ignored."""
        for op in COMPARISONS:  # two-character operators are tried first
            if op in text:
                column, value = text.split(op, 1)
                return cls(column.strip(), op, value.strip())
        raise IndexError_(
            f"cannot parse filter {text!r}: expected column<op>value with op in "
            f"{' '.join(COMPARISONS)}, e.g. hook_m>=0.1"
        )

    def sql(self) -> tuple[str, Any]:
        return f"{self.column} {self.op} ?", self.value

    def __repr__(self) -> str:
        return f"Filter({self.column}{self.op}{self.value!r})"


def select_sql(
    filters: Sequence[Filter],
    order_by: str,
    limit: int | None,
    clauses: Sequence[tuple[str, Sequence[Any]]] = (),
) -> tuple[str, list[Any]]:
    """The SELECT statement and its parameters for :func:`Archive.list_runs`.

    ``clauses`` are extra (sql, params) conditions ANDed with the filters.
    """
    if order_by.lstrip("-") not in INDEX_COLUMNS:
        raise IndexError_(f"cannot order by unknown column {order_by!r}")
    params: list[Any] = [p for _, ps in clauses for p in ps]
    clauses_sql = [f"({c})" for c, _ in clauses]
    for f in filters:
        clause, value = f.sql()
        clauses_sql.append(clause)
        params.append(value)
    where = f" WHERE {' AND '.join(clauses_sql)}" if clauses_sql else ""
    direction = "DESC" if order_by.startswith("-") else "ASC"
    sql = f"SELECT * FROM runs{where} ORDER BY {order_by.lstrip('-')} {direction}, run_id"
    if limit is not None:
        sql += f" LIMIT {int(limit)}"
    return sql, params
