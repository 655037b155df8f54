"""Batch jobs: sweeps over scene fields, run on local processes or a Dask cluster, with the
calling process as the archive's single writer and a summary table per job.

Typical use (what ``bowlrec batch`` does)::

    from bowlrec.archive import Archive
    from bowlrec.batch import load_job, run_job, write_table

    job = load_job("examples/jobs/speed-rev-grid.json")
    result = run_job(job, Archive("runs"), base_dir="examples/jobs")
    write_table(result, "speed-rev-grid")

Imports neither numba nor dask until something is run.
"""

from .job import (
    JOB_FORMAT,
    JobError,
    JobSpec,
    Point,
    PreparedRun,
    apply_override,
    job_schema_text,
    latin_hypercube,
    load_job,
    parse_path,
    prepare_runs,
)
from .runner import (
    FAILED_OUTCOMES,
    METRIC_COLUMNS,
    BatchProgress,
    BatchResult,
    InlineExecutor,
    run_job,
    run_prepared,
    simulate_chunk,
)
from .table import table_columns, table_rows, write_table

__all__ = [
    "FAILED_OUTCOMES",
    "JOB_FORMAT",
    "METRIC_COLUMNS",
    "BatchProgress",
    "BatchResult",
    "InlineExecutor",
    "JobError",
    "JobSpec",
    "Point",
    "PreparedRun",
    "apply_override",
    "job_schema_text",
    "latin_hypercube",
    "load_job",
    "parse_path",
    "prepare_runs",
    "run_job",
    "run_prepared",
    "simulate_chunk",
    "table_columns",
    "table_rows",
    "write_table",
]
