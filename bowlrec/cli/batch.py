"""``bowlrec batch JOB``: run a job's sweep into the archive and write its summary table."""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Annotated, Any

import typer

from bowlrec.archive.location import config_value
from bowlrec.errors import BowlrecError, JobError

from ._app import app
from ._common import (
    EXIT_INTERRUPTED,
    ArchiveOption,
    QuietOption,
    fail,
    interactive,
    open_archive,
    os_error_text,
    warn,
)
from ._first_use import first_use

if TYPE_CHECKING:
    from bowlrec.batch import BatchProgress


def _sigint_sets(cancel: threading.Event) -> Any:
    """Install a SIGINT handler that sets ``cancel``; a second Ctrl-C raises KeyboardInterrupt
    to stop at once."""

    def handler(signum: int, frame: FrameType | None) -> None:
        if cancel.is_set():
            raise KeyboardInterrupt
        cancel.set()
        typer.echo(
            "\ninterrupted: stopping after the runs in flight (Ctrl-C again: stop now) ...",
            err=True,
        )

    return signal.signal(signal.SIGINT, handler)


class _FirstFailure:
    """Passes table chunks on to the table writer and keeps the first failed row's error."""

    def __init__(self, write: Any) -> None:
        self.write = write
        self.error: str | None = None
        self.params: dict[str, Any] = {}

    def __call__(self, table: Any) -> None:
        if self.error is None and "failed" in table.status:
            i = table.status.index("failed")
            self.error = table.error[i] or "(no message)"
            self.params = {k: v[i] for k, v in table.params.items()}
        self.write(table)


@app.command()
def batch(
    job: Annotated[Path, typer.Argument(help="Job file (.json, .yaml, .yml), format bowlrec-job.")],
    archive: ArchiveOption = None,
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers",
            "-j",
            min=0,
            help="Local worker processes (default: all cores; 0: simulate in this process).",
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            envvar="BOWLREC_SCHEDULER",
            help="Run on a dask.distributed cluster, e.g. tcp://127.0.0.1:8786 (needs "
            "'bowlrec[dask]'); default: $BOWLREC_SCHEDULER or 'scheduler' in the config file.",
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Summary table: a file ending .csv, .parquet, .json or .jsonl, or a prefix "
            "for PREFIX.csv and PREFIX.parquet (default: the job file's stem + '-summary', "
            "e.g. grid-summary for grid.json).",
        ),
    ] = None,
    no_archive: Annotated[
        bool,
        typer.Option("--no-archive", help="Store nothing: write only the summary table."),
    ] = False,
    worker_writes: Annotated[
        str,
        typer.Option(
            "--worker-writes",
            help="Dask workers seal segments themselves (yes), ship them back to this process "
            "(no), or write when they see the archive's files (auto, by a probe file).",
        ),
    ] = "auto",
    replay_dir: Annotated[
        Path | None,
        typer.Option(
            "--replay-dir",
            help="Where the job's replay formats go (default: PREFIX/, or the table file's "
            "name without its suffix).",
        ),
    ] = None,
    chunk_size: Annotated[
        int | None,
        typer.Option(
            "--chunk-size", min=1, help="Runs per worker task (default: sized by run time)."
        ),
    ] = None,
    allow_failures: Annotated[
        bool,
        typer.Option(
            "--allow-failures",
            help="Exit 0 when some runs failed (their rows say why); by default failed runs "
            "make the exit status 1.",
        ),
    ] = False,
    quiet: QuietOption = False,
) -> None:
    """Run a batch job (sweeps of scenes) into the archive and write its summary table.

    Every run of the sweep not yet archived is simulated and added; one table row per run.
    Resumable: rerunning skips archived runs. Prints one summary line (also with --quiet);
    exits 1 when runs failed (unless --allow-failures), 130 after Ctrl-C.
    """
    from bowlrec.batch import TableWriter, load_job, table_paths
    from bowlrec.batch.manifest import run_recorded_job  # listed on the web app's Jobs page
    from bowlrec.batch.runner import param_columns
    from bowlrec.batch.table import param_types

    if not job.exists():
        fail(f"{job}: no such file")
    if worker_writes not in ("auto", "yes", "no"):
        fail(f"--worker-writes: {worker_writes!r} must be auto, yes or no")
    spec = load_job(job)
    from bowlrec.batch.job import job_unit_warnings

    for line in job_unit_warnings(spec, base_dir=job.parent):
        warn(f"{job}: {line}")
    store = None if no_archive else open_archive(archive)
    prefix = out if out is not None else Path(f"{job.stem}-summary")
    if no_archive and spec.formats:
        fail(
            f"{job}: formats {spec.formats} write replay files of archived runs; drop --no-archive"
        )
    if scheduler is None:
        scheduler = config_value("scheduler")
    columns = param_columns(spec)
    try:
        writer = TableWriter(table_paths(prefix), columns, param_types(spec, columns))
    except OSError as err:  # before anything runs: the table's place cannot be written
        fail(f"summary table: {os_error_text(err)}", code=1)
    cancel = threading.Event()
    previous = _sigint_sets(cancel)
    show = interactive(quiet)
    failures = _FirstFailure(writer.write)
    last = _LastProgress()
    compiling = bool(first_use("batch")) if scheduler is None else False
    unrecorded: list[OSError] = []  # why the web app's Jobs page cannot list this batch
    try:
        with _progress(show, spec.count(), last, compiling) as update:
            result = run_recorded_job(
                spec,
                store,
                base_dir=job.parent,
                workers=workers,
                scheduler=scheduler,
                chunk_size=chunk_size,
                progress=update,
                cancel=cancel,
                replay_dir=replay_dir if replay_dir is not None else _replay_default(prefix),
                worker_writes=worker_writes,
                sink=failures,
                unrecorded=unrecorded.append,
            )
    except KeyboardInterrupt:  # the second Ctrl-C (the handler above)
        writer.abort()
        signal.signal(signal.SIGINT, previous)
        kept = (
            "nothing is archived"
            if store is None
            else f"the runs sealed so far are kept in {store.root} (about {last.done} of "
            f"{spec.count()} runs had finished)"
        )
        typer.echo(
            f"interrupted again: stopped at once; {kept}; no summary table was written; rerun "
            "the same command to do the rest",
            err=True,
        )
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except BaseException as err:
        writer.abort()
        if isinstance(err, JobError):
            raise JobError(f"{job}: {err}") from None
        if isinstance(err, RuntimeError | OSError) and not isinstance(err, BowlrecError):
            fail(str(err))  # e.g. a scheduler that cannot be reached
        raise
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        paths = writer.close()
    except OSError as err:
        kept = "" if store is None else f"; the {result.counts['ok']} run(s) archived are kept"
        fail(
            f"could not write the summary table {prefix} ({err.strerror or err}){kept}: rerun "
            "the same command"
        )
    c = result.counts
    added = "simulated" if store is None else "new"
    typer.echo(
        f"{result.n_rows + result.not_reached} runs: {c['ok']} {added}, "
        f"{c['archived']} already archived, {c['failed']} failed"
        + (f", {c['cancelled']} not run" if c["cancelled"] else "")
        + (f", {result.not_reached} not reached" if result.not_reached else "")
        + f" ({result.simulated} simulated in {result.elapsed_s:.1f} s)",
        err=True,
    )
    if unrecorded and result.error is None:  # else the error line says why
        cause = unrecorded[0]
        why = (
            f"{cause.strerror}: {cause.filename}"
            if cause.strerror and cause.filename
            else str(cause)
        )
        warn(f"the web app's Jobs page will not list this batch ({why})")
    if failures.error is not None and result.error is None:  # else the error line says why
        from bowlrec.spec.errors import printable

        at = ", ".join(f"{k}={_value(v)}" for k, v in failures.params.items())
        typer.echo(
            f"first failure{f' ({at})' if at else ''}: {printable(failures.error)}"
            + (f"; every failed row's error is in {paths[0]}" if paths else ""),
            err=True,
        )
    if not quiet:
        for p in paths:
            typer.echo(f"table: {p}", err=True)
        if out is None and not any(p.suffix == ".parquet" for p in paths):
            typer.echo("note: install pyarrow for the Parquet table", err=True)
    if result.error is not None:
        typer.echo(
            f"error: {result.error}; the {c['ok']} run(s) archived before it are kept and the "
            "summary table was written; rerun the same command to do the rest",
            err=True,
        )
        raise typer.Exit(1)
    if result.cancelled:
        if store is None:
            typer.echo(
                f"interrupted: the table holds the {c['ok']} runs that finished (up to the last "
                "run reached, the others are 'cancelled' rows; without an archive a rerun "
                "simulates everything again)",
                err=True,
            )
        else:
            typer.echo(
                f"interrupted: {c['ok']} finished runs were added to {store.root}; rerun the "
                "same command to do the rest",
                err=True,
            )
        raise typer.Exit(EXIT_INTERRUPTED)
    if c["failed"] and not allow_failures:
        raise typer.Exit(1)


def _value(v: Any) -> str:
    """A swept value as the failure line shows it: floats to 6 significant digits, anything
    else on one line and cut to :data:`~bowlrec.spec.errors.MAX_ECHO` characters."""
    from bowlrec.spec.errors import MAX_ECHO, printable

    return f"{v:.6g}" if isinstance(v, float) else printable(str(v), MAX_ECHO)


class _LastProgress:
    """The last progress report (for the message after a second Ctrl-C)."""

    done = 0

    def __call__(self, p: BatchProgress) -> None:
        self.done = p.done


def _replay_default(prefix: Path) -> Path:
    """Replays go to PREFIX/ (for ``--out table.csv``: ``table/``)."""
    from bowlrec.batch import table_paths

    return prefix.with_suffix("") if table_paths(prefix) == [prefix] else prefix


class _progress:
    """A rich progress bar (runs, rate, ETA) on a terminal; a no-op callback otherwise."""

    def __init__(self, show: bool, total: int, last: _LastProgress, compiling: bool) -> None:
        self.compiling = compiling  # the workers compile kernels first (first use)
        self.show = show
        self.total = total
        self.last = last
        self.bar: Any = None
        self.task: Any = None

    def __enter__(self) -> Any:
        if not self.show:
            return self.last
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = Progress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            transient=True,
        )
        self.bar.__enter__()
        starting = "compiling the kernels: first use" if self.compiling else "loading the kernels"
        self.task = self.bar.add_task(
            f"batch: starting workers ({starting})", total=self.total, rate=""
        )
        return self.update

    def update(self, p: BatchProgress) -> None:
        self.last(p)
        if p.done == 0:
            return
        desc = f"batch ({p.failed} failed)" if p.failed else "batch"
        rate = f"{p.rate_per_s:.1f} runs/s"
        self.bar.update(self.task, completed=p.done, rate=rate, description=desc)

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)
