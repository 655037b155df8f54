"""``bowlrec batch JOB``: run a job's sweep into the archive and write its summary table."""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ._app import app
from ._common import ArchiveOption, QuietOption, fail, interactive, open_archive

if TYPE_CHECKING:
    from bowlrec.batch import BatchProgress

#: exit code after Ctrl-C (128 + SIGINT), as shells report it
EXIT_INTERRUPTED = 130


def _sigint_sets(cancel: threading.Event) -> Any:
    """Install a SIGINT handler that sets ``cancel`` (a second Ctrl-C interrupts at once)."""

    def handler(signum: int, frame: FrameType | None) -> None:
        if cancel.is_set():
            raise KeyboardInterrupt
        cancel.set()
        typer.echo("\ninterrupted: stopping after the runs in flight ...", err=True)

    return signal.signal(signal.SIGINT, handler)


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
            help="Summary table prefix: writes PREFIX.csv and PREFIX.parquet (default: "
            "<job file stem>-summary in the current directory).",
        ),
    ] = None,
    replay_dir: Annotated[
        Path | None,
        typer.Option("--replay-dir", help="Where the job's replay formats go (default: PREFIX/)."),
    ] = None,
    chunk_size: Annotated[
        int | None, typer.Option("--chunk-size", min=1, help="Runs per worker task.")
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Run a batch job (sweeps of scenes) into the archive and write its summary table.

    Every run of the sweep not yet archived is simulated and added; one table row per run.
    Resumable: rerunning skips archived runs.
    """
    from bowlrec.batch import JobError, load_job, prepare_runs, run_prepared, write_table

    if not job.exists():
        fail(f"{job}: no such file")
    try:
        spec = load_job(job)
    except JobError as err:
        fail(str(err))
    store = open_archive(archive)
    try:
        prepared = prepare_runs(spec, base_dir=job.parent, balls=store.balls)
    except JobError as err:
        fail(f"{job}: {err}")
    prefix = out if out is not None else Path(f"{job.stem}-summary")
    if scheduler is None:
        from bowlrec.archive.location import config_value

        scheduler = config_value("scheduler")
    cancel = threading.Event()
    previous = _sigint_sets(cancel)
    show = interactive(quiet)
    try:
        with _progress(show, len(prepared)) as update:
            result = run_prepared(
                prepared,
                store,
                workers=workers,
                scheduler=scheduler,
                chunk_size=chunk_size,
                progress=update,
                cancel=cancel,
                formats=spec.formats,
                replay_dir=replay_dir if replay_dir is not None else prefix,
            )
    except RuntimeError as err:
        fail(str(err))
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        paths = write_table(result, prefix)
    except OSError as err:
        fail(
            f"could not write the summary table {prefix}.csv ({err.strerror or err}); the "
            f"{result.counts['ok']} run(s) archived are kept: rerun the same command"
        )
    c = result.counts
    if not quiet:
        typer.echo(
            f"{len(result.rows)} runs: {c['ok']} new, {c['archived']} already archived, "
            f"{c['failed']} failed"
            + (f", {c['cancelled']} not run" if c["cancelled"] else "")
            + f" ({result.simulated} simulated in {result.elapsed_s:.1f} s)",
            err=True,
        )
        for p in paths:
            typer.echo(f"table: {p}", err=True)
        if len(paths) == 1:
            typer.echo("note: install pyarrow for the Parquet table", err=True)
    if result.error is not None:
        typer.echo(
            f"error: {result.error}; the {c['ok']} run(s) archived before it are kept and the "
            "summary table was written; rerun the same command to do the rest",
            err=True,
        )
        raise typer.Exit(1)
    if result.cancelled:
        typer.echo(
            f"interrupted: {c['ok']} finished runs were added to {store.root}; rerun the same "
            "command to do the rest",
            err=True,
        )
        raise typer.Exit(EXIT_INTERRUPTED)


class _progress:
    """A rich progress bar (runs, rate, ETA) on a terminal; a no-op callback otherwise."""

    def __init__(self, show: bool, total: int) -> None:
        self.show = show
        self.total = total
        self.bar: Any = None
        self.task: Any = None

    def __enter__(self) -> Any:
        if not self.show:
            return None
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
            TextColumn("{task.fields[rate]:.1f} runs/s"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            transient=True,
        )
        self.bar.__enter__()
        self.task = self.bar.add_task("batch", total=self.total, rate=0.0)
        return self.update

    def update(self, p: BatchProgress) -> None:
        desc = f"batch ({p.failed} failed)" if p.failed else "batch"
        self.bar.update(self.task, completed=p.done, rate=p.rate_per_s, description=desc)

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)
