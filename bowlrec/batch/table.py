"""The batch table: one row per run, as Arrow, a NumPy structured array, CSV, Parquet or JSON.

Columns, in order: ``index`` (the run's position in the job), one column per swept path (named
by the path, e.g. ``delivery.omega_radps[1]``; ``scene`` for a ``scenes`` block), ``run_id``,
``status`` (ok | archived | failed | cancelled), ``error``, then the summary metrics (units in
the names): ``outcome``, ``slide_m``, ``hook_m``, ``pocket_deg``, ``time_s``, ``x_end_m``,
``y_end_m``, ``speed_end_mps``, ``rev_rate_end_rpm``, ``n_steps``, ``n_rhs``, ``n_events``.

Missing values (no hook for a gutter ball, no metrics for a run that was not simulated) are
null in Arrow, Parquet and JSON and empty in CSV. In the NumPy structured array they are NaN in
float columns, -1 in integer columns and "" in text columns. Object or list values of a swept
path are JSON text. No value is ever ±inf.

Writers stream chunk by chunk (:class:`TableWriter`): a job of millions of runs is written in
flat memory. Each file is written under a temporary name and renamed when complete.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.atomic_files import atomic_path
from bowlrec.batch.job import GridSweep, Linspace, PointsSweep, ScenesSweep, ZipSweep
from bowlrec.core.trajectory import FLOAT_METRICS, INT_METRICS
from bowlrec.errors import MissingExtraError

from .chunks import METRIC_COLUMNS, ChunkTable

if TYPE_CHECKING:
    import pyarrow as pa

    from .job import JobSpec

__all__ = [
    "STATUSES",
    "TABLE_SUFFIXES",
    "BatchResult",
    "TableWriter",
    "param_types",
    "table_columns",
    "table_rows",
    "to_arrow",
    "to_numpy",
    "write_table",
]

#: file types a table is written as, by suffix
TABLE_SUFFIXES = (".csv", ".parquet", ".json", ".jsonl")
_TEXT = ("run_id", "status", "error")


#: row statuses: simulated and added now / found in the archive / not run (see error) /
#: not reached before cancellation
STATUSES = ("ok", "archived", "failed", "cancelled")


@dataclass
class BatchResult:
    """What a batch did: its table (one row per run, job order) and totals.

    tables: the table's chunks in job order (empty when they went to a ``sink``; see
    :mod:`bowlrec.batch.table` for the columns); param_columns: the parameter column names in
    order; counts: rows per status (ok | archived | failed | cancelled); not_reached: runs after
    the last row, when the batch stopped early (they have no rows); simulated: runs
    simulated now; simulate_s: summed kernel time in the workers (s); write_s: time spent
    sealing and registering segments (s, workers and this process); elapsed_s: wall time (s).
    """

    param_columns: list[str]
    tables: list[ChunkTable] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(STATUSES, 0))
    simulated: int = 0
    cancelled: bool = False
    elapsed_s: float = 0.0
    simulate_s: float = 0.0
    write_s: float = 0.0
    replays: list[Path] = field(default_factory=list)
    #: runs after the table's last row that were never reached (a cancelled or failed batch)
    not_reached: int = 0
    #: why the batch stopped early when writing failed (e.g. a full disk); None otherwise
    error: str | None = None

    def count(self, status: str) -> int:
        return self.counts[status]

    @property
    def n_rows(self) -> int:
        return sum(self.counts.values())

    @property
    def rows(self) -> list[dict[str, Any]]:
        """The table as one dict per row (None for absent values); built on each access."""

        return table_rows(self)


def table_columns(param_columns: Sequence[str]) -> list[str]:
    """Every column of the table for these parameter columns."""
    return ["index", *param_columns, "run_id", "status", "error", *METRIC_COLUMNS]


def _kind(values: Iterable[Any]) -> str:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "bool"
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int64"
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
        return "float64"
    return "string"


def param_types(job: JobSpec, columns: Sequence[str]) -> dict[str, str]:
    """Each parameter column's type (bool, int64, float64 or string), from the values the
    job lists (ranges and linspaces are float64), so every chunk has the same schema."""

    seen: dict[str, list[Any]] = {c: [] for c in columns}
    for block in job.blocks():
        if isinstance(block, ScenesSweep):
            seen["scene"].append("")
        elif isinstance(block, PointsSweep):
            for point in block.points_:
                for k, v in point.items():
                    seen[k].append(v)
        elif isinstance(block, GridSweep | ZipSweep):
            for k, axis in block.axes.items():
                seen[k].extend([0.0] if isinstance(axis, Linspace) else axis)
        else:
            for k in block.axes:
                seen[k].append(0.0)
    return {c: _kind(v) for c, v in seen.items()}


def _cell(value: Any) -> Any:
    if isinstance(value, dict | list | tuple):
        return json.dumps(value, separators=(",", ":"))
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _param_values(table: ChunkTable, name: str) -> list[Any]:
    values = table.params.get(name)
    if values is None:
        return [None] * len(table)
    if isinstance(values, np.ndarray):
        return values.tolist()
    return list(values)


def table_rows(result: BatchResult) -> list[dict[str, Any]]:
    """The result's rows as dicts (None for absent values; non-scalars as JSON text)."""
    out = []
    for table in result.tables:
        params = {c: _param_values(table, c) for c in result.param_columns}
        metrics = {k: table.metrics[k].tolist() for k in METRIC_COLUMNS}
        for i in range(len(table)):
            has = bool(table.has_metrics[i])
            row: dict[str, Any] = {"index": int(table.index[i])}
            row.update({c: _cell(params[c][i]) for c in result.param_columns})
            row.update(run_id=table.run_id[i], status=table.status[i], error=table.error[i])
            for k in METRIC_COLUMNS:
                v = metrics[k][i] if has else None
                absent = (isinstance(v, float) and math.isnan(v)) or (k == "pinfall" and v == -1)
                row[k] = None if absent else v
            out.append(row)
    return out


def _arrow_chunk(table: ChunkTable, params: Sequence[str], types: dict[str, str]) -> pa.Table:
    import pyarrow as pa

    arrow_types = {"bool": pa.bool_, "int64": pa.int64, "float64": pa.float64, "string": pa.string}

    arrays: list[Any] = [pa.array(table.index, type=pa.int64())]
    for c in params:
        values = table.params.get(c)
        kind = types.get(c, "string")
        if isinstance(values, np.ndarray) and kind == "float64":
            arrays.append(pa.array(values, type=pa.float64(), from_pandas=True))
            continue
        cells = [_cell(v) for v in _param_values(table, c)]
        if kind == "string":
            cells = [None if v is None else str(v) for v in cells]
        elif kind == "float64":
            cells = [None if v is None else float(v) for v in cells]
        arrays.append(pa.array(cells, type=arrow_types[kind]()))
    for c in _TEXT:
        arrays.append(pa.array(getattr(table, c), type=pa.string()))
    missing = ~table.has_metrics
    arrays.append(pa.array(table.metrics["outcome"], type=pa.string(), mask=missing))
    for k in FLOAT_METRICS:
        v = table.metrics[k]
        arrays.append(pa.array(v, type=pa.float64(), mask=missing | ~np.isfinite(v)))
    for k in INT_METRICS:
        arrays.append(pa.array(table.metrics[k], type=pa.int64(), mask=missing))
    pinfall = table.metrics["pinfall"]
    arrays.append(pa.array(pinfall, type=pa.int64(), mask=missing | (pinfall < 0)))
    arrays.append(pa.array(table.metrics["leave"], type=pa.string(), mask=missing))
    return pa.table(arrays, names=table_columns(params))


def to_arrow(result: BatchResult, job: JobSpec | None = None) -> pa.Table:
    """The result's table as a pyarrow Table (nulls for absent values)."""
    import pyarrow as pa

    types = param_types(job, result.param_columns) if job is not None else {}
    if job is None:  # infer from the values
        for c in result.param_columns:
            types[c] = _kind(v for t in result.tables for v in _param_values(t, c))
    chunks = [_arrow_chunk(t, result.param_columns, types) for t in result.tables]
    if not chunks:
        empty = ChunkTable.empty(np.zeros(0, dtype=np.int64), {})
        return _arrow_chunk(empty, result.param_columns, types)
    return pa.concat_tables(chunks)


def to_numpy(result: BatchResult) -> np.ndarray:
    """The result's table as a NumPy structured array: absent values are NaN (float), -1
    (integer) or "" (text); parameters that are not all numbers (or all present booleans) are
    JSON text."""
    n = result.n_rows
    rows_params = {
        c: [v for t in result.tables for v in _param_values(t, c)] for c in result.param_columns
    }
    fields: list[tuple[str, Any]] = [("index", np.int64)]
    param_arrays = {}
    for c, values in rows_params.items():
        kind = _kind(values)
        if kind in ("int64", "float64"):
            arr = np.array([np.nan if v is None else v for v in values], dtype=np.float64)
            if kind == "int64":
                arr = np.array([-1 if v is None else v for v in values], dtype=np.int64)
        elif kind == "bool" and None not in values:
            arr = np.array([bool(v) for v in values])
        else:
            arr = np.array(["" if v is None else str(_cell(v)) for v in values])
        param_arrays[c] = arr
        fields.append((c, arr.dtype))
    text = {
        c: np.array(["" if v is None else v for t in result.tables for v in getattr(t, c)])
        for c in _TEXT
    }
    has = (
        np.concatenate([t.has_metrics for t in result.tables])
        if result.tables
        else np.zeros(0, bool)
    )
    outcome = np.array(
        [
            "" if (v is None or not h) else v
            for t in result.tables
            for v, h in zip(t.metrics["outcome"], t.has_metrics, strict=True)
        ]
    )
    for c in _TEXT:
        fields.append((c, text[c].dtype if n else "U1"))
    fields.append(("outcome", outcome.dtype if n else "U1"))
    fields += [(k, np.float64) for k in FLOAT_METRICS]
    fields += [(k, np.int64) for k in INT_METRICS]
    leave = np.array(
        [
            "" if (v is None or not h) else v
            for t in result.tables
            for v, h in zip(t.metrics["leave"], t.has_metrics, strict=True)
        ]
    )
    fields += [("pinfall", np.int64), ("leave", leave.dtype if n else "U1")]
    out = np.zeros(n, dtype=fields)
    if not n:
        return out
    out["index"] = np.concatenate([t.index for t in result.tables])
    for c, arr in param_arrays.items():
        out[c] = arr
    for c in _TEXT:
        out[c] = text[c]
    out["outcome"] = outcome
    for k in FLOAT_METRICS:
        v = np.concatenate([t.metrics[k] for t in result.tables])
        out[k] = np.where(has & np.isfinite(v), v, np.nan)
    for k in INT_METRICS:
        v = np.concatenate([t.metrics[k] for t in result.tables])
        out[k] = np.where(has, v, -1)
    out["pinfall"] = np.where(
        has, np.concatenate([t.metrics["pinfall"] for t in result.tables]), -1
    )
    out["leave"] = leave
    return out


class TableWriter:
    """Streams table chunks to files (``.csv``, ``.parquet``, ``.json``, ``.jsonl``), each
    under a temporary name until :meth:`close` renames it; :meth:`abort` removes them.

    CSV and Parquet go through pyarrow when it is installed (CSV falls back to the standard
    library without it; Parquet needs it)."""

    def __init__(
        self, paths: Sequence[Path], param_columns: Sequence[str], types: dict[str, str]
    ) -> None:

        self.paths = [Path(p) for p in paths]
        self.params = list(param_columns)
        self.types = types
        self.columns = table_columns(self.params)
        self._stack = ExitStack()
        self._writers: list[Any] = []
        self._json_first = True
        self._has_arrow = _has_pyarrow()
        for path in self.paths:
            suffix = path.suffix.lower()
            if suffix == ".parquet" and not self._has_arrow:
                raise MissingExtraError(
                    f"{path}: Parquet needs pyarrow, which is not installed; install it with: "
                    "pip install 'bowlrec[table]'",
                    name="pyarrow",
                )
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = self._stack.enter_context(atomic_path(path))
            self._writers.append((suffix, tmp, None))
        self._ok = False

    def write(self, table: ChunkTable) -> None:
        """Append one chunk of rows."""
        batch = _arrow_chunk(table, self.params, self.types) if self._has_arrow else None
        rows: list[dict[str, Any]] | None = None
        for k, (suffix, tmp, handle) in enumerate(self._writers):
            text = suffix in (".json", ".jsonl") or (suffix == ".csv" and batch is None)
            if text and rows is None:
                rows = _chunk_rows(table, self.params)
            if handle is None:
                handle = self._open(suffix, tmp, batch)
                self._writers[k] = (suffix, tmp, handle)
            if suffix == ".parquet" or (suffix == ".csv" and batch is not None):
                handle.write_table(batch)
            elif suffix == ".csv":
                handle[1].writerows(
                    {c: ("" if r[c] is None else r[c]) for c in self.columns} for r in rows or []
                )
            elif suffix == ".jsonl":
                handle.write("".join(json.dumps(r, allow_nan=False) + "\n" for r in rows or []))
            else:
                for r in rows or []:
                    handle.write(
                        ("[\n" if self._json_first else ",\n") + json.dumps(r, allow_nan=False)
                    )
                    self._json_first = False

    def _open(self, suffix: str, tmp: Path, batch: Any) -> Any:
        if suffix == ".parquet":
            import pyarrow.parquet as pq

            return pq.ParquetWriter(tmp, batch.schema)
        if suffix == ".csv" and batch is not None:
            import pyarrow.csv as pcsv

            return pcsv.CSVWriter(tmp, batch.schema)
        fh = open(tmp, "w", newline="", encoding="utf-8")  # noqa: SIM115 (closed in close())
        self._stack.callback(fh.close)
        if suffix == ".csv":
            writer = csv.DictWriter(fh, fieldnames=self.columns)
            writer.writeheader()
            return (fh, writer)
        return fh

    def close(self) -> list[Path]:
        """Finish every file and move it into place; the paths written."""
        empty = ChunkTable.empty(np.zeros(0, dtype=np.int64), {})
        for k, (suffix, tmp, handle) in enumerate(self._writers):
            if handle is None:  # no rows: still a valid file with the header / schema
                self.write(empty)
                suffix, tmp, handle = self._writers[k]
            if suffix == ".json":
                handle.write("[]\n" if self._json_first else "\n]\n")
                self._json_first = False
            if suffix in (".parquet",) or (suffix == ".csv" and self._has_arrow):
                handle.close()
            elif isinstance(handle, tuple):
                handle[0].flush()
            else:
                handle.flush()
        self._ok = True
        self._stack.close()
        return self.paths

    def abort(self) -> None:
        """Drop the unfinished files (nothing is moved into place)."""
        for suffix, _tmp, handle in self._writers:
            if handle is not None and (
                suffix == ".parquet" or (suffix == ".csv" and self._has_arrow)
            ):
                handle.close()
        self._stack.__exit__(RuntimeError, RuntimeError("aborted"), None)


def _chunk_rows(table: ChunkTable, params: Sequence[str]) -> list[dict[str, Any]]:

    result = BatchResult(list(params), [table])
    return table_rows(result)


def _has_pyarrow() -> bool:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def table_paths(prefix: str | Path) -> list[Path]:
    """Where a table goes: a path with a :data:`TABLE_SUFFIXES` suffix is that one file; any
    other is a prefix: ``PREFIX.csv`` and, with pyarrow, ``PREFIX.parquet``."""
    p = Path(prefix)
    if p.suffix.lower() in TABLE_SUFFIXES:
        return [p]
    out = [p.with_name(p.name + ".csv")]
    if _has_pyarrow():
        out.append(p.with_name(p.name + ".parquet"))
    return out


def write_table(result: BatchResult, prefix: str | Path, job: JobSpec | None = None) -> list[Path]:
    """Write a kept table (see :func:`table_paths`); each file complete or absent. Returns
    the paths written."""
    cols = result.param_columns
    types = (
        param_types(job, cols)
        if job is not None
        else {c: _kind(v for t in result.tables for v in _param_values(t, c)) for c in cols}
    )
    writer = TableWriter(table_paths(prefix), cols, types)
    try:
        for table in result.tables:
            writer.write(table)
    except BaseException:
        writer.abort()
        raise
    return writer.close()
