"""A run as a CSV table (``.csv``) for spreadsheets and data frames.

A run with samples: a header, then one row per sample, the columns of
:func:`~bowlrec.core.trajectory.sample_columns` (each named with its unit: ``t_s``, ``x_m``,
``vx_mps``, ``q_w``, ``omega_x_radps``, ``phase``, ``mu``, ``normal_force_N``, ``energy_J``,
per-term torques ``tau_dev_x_Nm`` ... when recorded; lane frame, SI units), the same columns as
:meth:`~bowlrec.core.trajectory.Trajectory.to_dataframe`. A summary-only run
(``options.record = 'summary'``): a header of the summary's fields
(:meth:`~bowlrec.core.trajectory.Summary.to_dict`) and one row. Several runs in one file: one
summary row per run, after ``run_id`` and ``name`` columns.

Cells: floats as ``float.__repr__`` (the shortest text that reads back to the same float, bit
for bit), integers in decimal, text quoted when it holds a comma or quote, an empty cell for a
metric without a value (None or NaN). UTF-8, ``\\n`` line ends. The file is written whole or
not at all (:func:`~bowlrec.atomic_files.atomic_path`). Only the standard library and NumPy.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.atomic_files import atomic_path
from bowlrec.core.trajectory import Summary, sample_columns

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory

    from .common import RunData

__all__ = ["RUN_COLUMNS", "write_csv", "write_csv_many", "write_run_csv"]

#: the columns before the summary's in a file of several runs
RUN_COLUMNS = ("run_id", "name")


def cell(value: Any) -> str:
    """One CSV cell: ``float.__repr__`` of a float, decimal of an integer, text as is; an empty
    cell for None and NaN."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, float | np.floating):
        number = float(value)
        return "" if math.isnan(number) else float.__repr__(number)
    if isinstance(value, int | np.integer):
        return str(int(value))
    return str(value)


def _column_cells(values: np.ndarray[Any, Any]) -> list[str]:
    """The cells of one sample column."""
    items = values.tolist()
    if values.dtype.kind == "f" and bool(np.isfinite(values).all()):
        return list(map(float.__repr__, items))
    return [cell(v) for v in items]


def _write(
    path: str | os.PathLike[str], header: Sequence[str], rows: Iterable[Sequence[str]]
) -> Path:
    """Write ``header`` and ``rows`` (cells already text) to ``path`` atomically; the path."""
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
    return target


def _summary_cells(summary: Summary) -> list[str]:
    return [cell(v) for v in summary.to_dict().values()]


def write_csv(trajectory: Trajectory, path: str | os.PathLike[str]) -> Path:
    """Write ``trajectory`` to the CSV file ``path`` (replaced if it exists; no suffix added):
    one row per sample, or its summary as one row when it has no samples; return the path."""
    if trajectory.n_samples == 0:
        summary = trajectory.summary
        return _write(path, list(summary.to_dict()), [_summary_cells(summary)])
    columns = sample_columns(trajectory)
    cells = [_column_cells(values) for values in columns.values()]
    return _write(path, list(columns), zip(*cells, strict=True))


def write_run_csv(run: RunData, path: str | os.PathLike[str]) -> Path:
    """:func:`write_csv` of the run's trajectory (the registry's writer)."""
    return write_csv(run.trajectory, path)


def write_csv_many(runs: Sequence[RunData], path: str | os.PathLike[str]) -> Path:
    """Write one row per run to the CSV file ``path``: its ``run_id`` (empty for an unarchived
    run), its scene's ``name`` and its summary (:meth:`Summary.to_dict`), whether or not it has
    samples; return the path. No runs: the header alone."""
    header = [*RUN_COLUMNS, *(f.name for f in fields(Summary))]
    rows = [[cell(r.run_id), r.name, *_summary_cells(r.trajectory.summary)] for r in runs]
    return _write(path, header, rows)
