"""The batch summary table: one row per run, written as CSV (always) and Parquet (pyarrow).

Columns, in order: ``index`` (the run's position in the job), one column per swept path (named
by the path, e.g. ``delivery.omega_radps[1]``; ``scene`` for a ``scenes`` block), ``run_id``,
``status`` (ok | archived | failed | cancelled), ``error``, then the summary metrics (SI units
in the names: slide_m, hook_m, pocket_deg, time_s, ...). Missing values are empty in the CSV and
null in Parquet; object or list values of a swept path are written as JSON text.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .runner import METRIC_COLUMNS, BatchResult

__all__ = ["table_columns", "table_rows", "write_table"]


def table_columns(param_columns: Sequence[str]) -> list[str]:
    """Every column of the table for these parameter columns."""
    return ["index", *param_columns, "run_id", "status", "error", *METRIC_COLUMNS]


def _cell(value: Any) -> Any:
    if isinstance(value, dict | list | tuple):
        return json.dumps(value, separators=(",", ":"))
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def table_rows(result: BatchResult) -> list[dict[str, Any]]:
    """The result's rows restricted to :func:`table_columns`, JSON-encoding non-scalars."""
    cols = table_columns(result.param_columns)
    return [{c: _cell(r.get(c)) for c in cols} for r in result.rows]


def _column_type(values: list[Any]) -> str:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "bool"
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int64"
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
        return "float64"
    return "string"


def _write_parquet(path: Path, columns: list[str], rows: list[dict[str, Any]]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = []
    for c in columns:
        values = [r[c] for r in rows]
        kind = _column_type(values)
        if kind == "string":
            values = [None if v is None else str(v) for v in values]
        elif kind == "float64":
            values = [None if v is None else float(v) for v in values]
        arrays.append(pa.array(values, type=getattr(pa, kind)()))
    pq.write_table(pa.table(arrays, names=columns), path)


def write_table(result: BatchResult, prefix: str | Path) -> list[Path]:
    """Write ``PREFIX.csv`` and, when pyarrow is installed, ``PREFIX.parquet`` (each atomically:
    complete or absent). Returns the paths written."""
    from bowlrec.sinks.atomic import atomic_path

    prefix = Path(prefix)
    prefix.parent.mkdir(parents=True, exist_ok=True)
    columns = table_columns(result.param_columns)
    rows = table_rows(result)
    out = []
    csv_path = prefix.with_name(prefix.name + ".csv")
    with atomic_path(csv_path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
    out.append(csv_path)
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return out
    pq_path = prefix.with_name(prefix.name + ".parquet")
    with atomic_path(pq_path) as tmp:
        _write_parquet(tmp, columns, rows)
    out.append(pq_path)
    return out
