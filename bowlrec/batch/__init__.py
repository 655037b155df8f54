"""Batch jobs: sweeps over scene fields, run chunk by chunk on local processes or a Dask cluster;
workers prepare, simulate and seal archive segments, the calling process registers them and
collects a summary table per job.

Typical use (what ``bowlrec batch`` does)::

    from bowlrec.archive import Archive
    from bowlrec.batch import load_job, run_job, write_table

    job = load_job("examples/jobs/speed-rev-grid.json")
    result = run_job(job, Archive("runs"), base_dir="examples/jobs")
    write_table(result, "speed-rev-grid")

or, from a notebook, :func:`simulate_many` (a table back, nothing stored by default).
Imports neither numba nor dask until something is run.
"""

from bowlrec.errors import JobError

from .chunks import FAILED_OUTCOMES, METRIC_COLUMNS, ChunkTable
from .job import PreparedRun, job_context, prepare_runs
from .job_spec import JOB_FORMAT, JobSpec, Point, job_schema_text, latin_hypercube, load_job
from .many import simulate_many
from .paths import apply_override, parse_path
from .runner import BatchProgress, InlineExecutor, run_job
from .table import (
    BatchResult,
    TableWriter,
    table_columns,
    table_paths,
    table_rows,
    to_arrow,
    to_numpy,
    write_table,
)

__all__ = [
    "FAILED_OUTCOMES",
    "JOB_FORMAT",
    "METRIC_COLUMNS",
    "BatchProgress",
    "BatchResult",
    "ChunkTable",
    "InlineExecutor",
    "JobError",
    "JobSpec",
    "Point",
    "PreparedRun",
    "TableWriter",
    "apply_override",
    "job_context",
    "job_schema_text",
    "latin_hypercube",
    "load_job",
    "parse_path",
    "prepare_runs",
    "run_job",
    "simulate_many",
    "table_columns",
    "table_paths",
    "table_rows",
    "to_arrow",
    "to_numpy",
    "write_table",
]
