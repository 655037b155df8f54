"""Jobs run from the command line (``bowlrec batch JOB``), recorded in the archive so that the
web app lists them beside the service's jobs.

The service keeps its jobs in ``ARCHIVE/jobs/`` (:mod:`bowlrec.service.jobs`: ``<id>.json``,
``<id>.spec.json``, ``<id>.runs``) and owns that directory: it resumes the jobs it finds there.
A batch run from the command line is recorded in the same files, in their own directory,
``ARCHIVE/jobs/cli/``, which the service leaves alone:

* ``<id>.spec.json``: ``{"job": spec}``, written once (atomically) before the first run;
* ``<id>.json``: the record (the service's record fields plus ``source``), replaced
  atomically at the start, at most once a second while the batch runs (not fsynced), and at
  the end (fsynced);
* ``<id>.runs``: ``index run_id`` lines: the workers append theirs (fsynced) before sealing a
  chunk, and every finished chunk adds its rows (the runs found archived already included)
  before they are registered;
* ``<id>.lock``: held (``flock``) by the batch for its lifetime. A record that still says
  ``running`` while nobody holds the lock is of a batch that was killed: it reads as
  ``interrupted``, with ``done`` counted from the runs file and the archive's index.

Each invocation is a job of its own (a rerun that finishes an interrupted batch lists the runs
it found archived as ``skipped``). Nothing here touches a segment or the index.
"""

from __future__ import annotations

import builtins
import contextlib
import fcntl
import json
import re
import time
import uuid
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from bowlrec.archive.run_id import RUN_ID_LENGTH
from bowlrec.atomic_files import atomic_path, unlocked

from .job_spec import JobSpec
from .runner import run_job

if TYPE_CHECKING:
    from bowlrec.archive import Archive

    from .chunks import ChunkTable
    from .runner import BatchProgress
    from .table import BatchResult

__all__ = [
    "CLI_JOBS_DIR",
    "RecordedJob",
    "RecordedJobs",
    "run_recorded_job",
]

#: where the command line's jobs are recorded, under the archive's root
CLI_JOBS_DIR = Path("jobs") / "cli"
#: seconds between progress records while a batch runs
PERSIST_INTERVAL_S = 1.0
#: failures kept in a record (the summary table has every failed row)
MAX_FAILURES = 100

_JOB_ID = re.compile(r"[0-9a-f]{1,64}")

Status = Literal["running", "done", "failed", "interrupted", "cancelled", "damaged"]


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


class RecordedFailure(BaseModel):
    """A failed run of a recorded job (as the service lists its failures)."""

    index: int
    run_id: str | None = None
    error: str


class RecordedJob(BaseModel):
    """A job run from the command line as the web app lists it: the fields of the service's
    job status, and ``source``."""

    model_config = ConfigDict(extra="ignore")

    job_id: str = Field(pattern=r"^[0-9a-f]{1,64}$")
    name: str
    status: Status
    total: int = Field(ge=0)
    done: int = Field(default=0, ge=0)
    failed: int = Field(default=0, ge=0)
    skipped: int = Field(default=0, ge=0)
    created_at: str
    updated_at: str
    error: str | None = None
    resumable: bool = False
    run_ids: list[str | None] | None = None
    failures: list[RecordedFailure] = Field(default_factory=list)
    source: str = "command line"


class _Recorder:
    """Records one batch: the spec and the record at the start, progress, the end.

    The record is for the web app's listing only: a write that fails (a full disk, a
    read-only ``jobs`` directory) turns recording off for the rest of the batch, which goes on
    (its own writes fail or not on their own); :attr:`error` says why it stopped."""

    def __init__(self, root: Path, job: JobSpec) -> None:
        self.dir = root / CLI_JOBS_DIR
        now = _now()
        self.rec = RecordedJob(
            job_id=uuid.uuid4().hex[:16], name=job.name, status="running", total=job.count(),
            created_at=now, updated_at=now,
        )  # fmt: skip
        base = self.dir / self.rec.job_id
        self.runs_path = base.with_suffix(".runs")
        #: why the job is not (or no longer) recorded; None while it is
        self.error: OSError | None = None
        self._lock: IO[str] | None = None
        self._last = 0.0
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            # the lock first: a reader never sees a running record nobody holds
            self._lock = open(base.with_suffix(".lock"), "a")  # noqa: SIM115
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            with atomic_path(base.with_suffix(".spec.json")) as tmp:
                tmp.write_text(json.dumps({"job": job.model_dump(mode="json", by_alias=True)}))
            self._persist(durable=True)
        except OSError as err:
            self._stop(err)
            for suffix in (".spec.json", ".lock"):  # nothing lists a job without its record
                with contextlib.suppress(OSError):
                    base.with_suffix(suffix).unlink(missing_ok=True)

    @property
    def recording(self) -> bool:
        return self.error is None

    def _stop(self, err: OSError) -> None:
        if self.error is None:
            self.error = err
        if self._lock is not None:
            self._lock.close()  # releases the lock: a running record reads as interrupted
            self._lock = None

    def _persist(self, durable: bool = False) -> None:
        with atomic_path(self.dir / f"{self.rec.job_id}.json", durable=durable) as tmp:
            tmp.write_text(self.rec.model_dump_json(exclude={"run_ids", "resumable"}, indent=1))

    def _write(self, action: Callable[[], None]) -> None:
        """``action`` (a write of the record's files) unless recording stopped; an OSError
        stops it."""
        if self.error is None:
            try:
                action()
            except OSError as err:
                self._stop(err)

    def progress(self, then: Callable[[BatchProgress], None] | None) -> Any:
        def update(p: BatchProgress) -> None:
            rec = self.rec
            rec.done, rec.failed, rec.skipped = p.done - p.failed, p.failed, p.archived
            if time.monotonic() - self._last >= PERSIST_INTERVAL_S:
                self._last = time.monotonic()
                rec.updated_at = _now()
                self._write(self._persist)
            if then is not None:
                then(p)

        return update

    def before_register(self, then: Callable[[ChunkTable], None] | None) -> Any:
        """A chunk's run IDs (the runs found archived too) and failures, before its runs
        reach the index."""

        def take(table: ChunkTable) -> None:
            lines = [
                f"{int(i)} {rid}\n"
                for i, rid in zip(table.index.tolist(), table.run_id, strict=True)
                if rid is not None
            ]

            def append() -> None:
                with open(self.runs_path, "a", encoding="ascii") as fh:
                    fh.write("".join(lines))

            self._write(append)
            room = MAX_FAILURES - len(self.rec.failures)
            for i, status in enumerate(table.status):
                if status == "failed" and room > 0:
                    room -= 1
                    self.rec.failures.append(
                        RecordedFailure(
                            index=int(table.index[i]),
                            run_id=table.run_id[i],
                            error=str(table.error[i]),
                        )
                    )
            if then is not None:
                then(table)

        return take

    def finish(
        self, status: Status, result: BatchResult | None = None, error: str | None = None
    ) -> None:
        rec = self.rec
        if result is not None:
            c = result.counts
            rec.done, rec.failed, rec.skipped = c["ok"] + c["archived"], c["failed"], c["archived"]
        rec.status, rec.error, rec.updated_at = status, error, _now()
        self._write(lambda: self._persist(durable=True))
        if self._lock is not None:
            self._lock.close()  # releases the lock
            self._lock = None


def run_recorded_job(
    job: JobSpec,
    archive: Archive | None,
    *,
    unrecorded: Callable[[OSError], None] | None = None,
    **options: Any,
) -> BatchResult:
    """:func:`~bowlrec.batch.runner.run_job` of ``job`` into ``archive``, recorded in
    ``ARCHIVE/jobs/cli/`` (module doc) so that the web app lists it; with no archive, just
    the run. ``options`` are run_job's (``progress`` and ``before_register`` are wrapped,
    ``run_log`` set when not given). When the record cannot be written, the batch runs on and
    ``unrecorded`` is called with the error at the end."""
    if archive is None:
        return run_job(job, None, **options)
    rec = _Recorder(Path(archive.root), job)
    if rec.recording:
        options["progress"] = rec.progress(options.get("progress"))
        options["before_register"] = rec.before_register(options.get("before_register"))
        options.setdefault("run_log", rec.runs_path)
    try:
        result = run_job(job, archive, **options)
    except KeyboardInterrupt:
        rec.finish("interrupted", error="stopped at once (Ctrl-C twice)")
        raise
    except BaseException as err:
        rec.finish("failed", error=f"{type(err).__name__}: {err}")
        raise
    if result.error is not None:
        rec.finish("failed", result, result.error)
    elif result.cancelled:
        rec.finish("interrupted", result, "interrupted (Ctrl-C): rerun the job to do the rest")
    else:
        rec.finish("done", result)
    if rec.error is not None and unrecorded is not None:
        unrecorded(rec.error)
    return result


class RecordedJobs:
    """The command line's jobs of the archive at ``root``, read from their files each time
    (a batch may be running in another process). A file that cannot be used lists its job
    as ``damaged``, with the reason in ``error``; it never breaks the listing."""

    def __init__(self, root: str | Path, present: Callable[[list[str]], set[str]] | None = None):
        self.dir = Path(root) / CLI_JOBS_DIR
        #: which run IDs the archive's index lists (to count an interrupted job's runs)
        self.present = present

    def ids(self) -> builtins.list[str]:
        try:
            names = [p.name for p in self.dir.iterdir() if p.name.endswith(".json")]
        except OSError:
            return []
        stems = (n[: -len(".json")] for n in names if not n.endswith(".spec.json"))
        return sorted(s for s in stems if _JOB_ID.fullmatch(s))

    def list(self) -> builtins.list[RecordedJob]:
        """Every recorded job, newest first (without run IDs)."""
        jobs = [self.get(i, with_runs=False) for i in self.ids()]
        found = [j for j in jobs if j is not None]
        return sorted(found, key=lambda j: (j.created_at, j.job_id), reverse=True)

    def get(self, job_id: str, with_runs: bool = True) -> RecordedJob | None:
        """The job, or None when there is no such command-line job."""
        if not _JOB_ID.fullmatch(job_id):
            return None
        path = self.dir / f"{job_id}.json"
        try:
            raw = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as err:
            return self._damaged(job_id, f"record unreadable ({err.strerror})")
        try:
            job = RecordedJob.model_validate_json(raw)
        except ValidationError as err:
            first = err.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            return self._damaged(job_id, f"record jobs/cli/{job_id}.json: {where} {first['msg']}")
        if job.job_id != job_id:
            return self._damaged(job_id, f"record jobs/cli/{job_id}.json names another job")
        if job.status == "running" and not self._held(job_id):
            job.status = "interrupted"
            job.error = "the batch stopped without finishing (killed?): rerun the job"
            if self.present is not None:
                ids = [r for r in self.run_ids(job_id, job.total) if r is not None]
                job.done = len(self.present(ids) & set(ids)) if ids else 0
        if with_runs:
            job.run_ids = self.run_ids(job_id, job.total)
        return job

    def spec(self, job_id: str) -> JobSpec | None:
        """The job's spec as recorded, or None when there is no such job or it is unreadable."""
        try:
            data = json.loads((self.dir / f"{job_id}.spec.json").read_text())
            return JobSpec.model_validate(data["job"])
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def run_ids(self, job_id: str, total: int) -> builtins.list[str | None]:
        """The job's run IDs by index (None: not known) from its runs file."""
        ids: builtins.list[str | None] = [None] * total
        try:
            text = (self.dir / f"{job_id}.runs").read_bytes().decode("ascii", errors="replace")
        except OSError:
            return ids
        for line in text.splitlines():
            index, _, rid = line.partition(" ")
            if index.isdigit() and int(index) < total and len(rid) == RUN_ID_LENGTH:
                ids[int(index)] = rid  # a line cut short by a kill is skipped
        return ids

    def _held(self, job_id: str) -> bool:
        """True while a batch holds the job's lock (it is running)."""
        lock = self.dir / f"{job_id}.lock"
        return lock.exists() and not unlocked(lock)

    def _damaged(self, job_id: str, reason: str) -> RecordedJob:
        try:
            stamp = (self.dir / f"{job_id}.json").stat().st_mtime
            when = datetime.fromtimestamp(stamp, UTC).isoformat(timespec="milliseconds")
        except OSError:
            when = _now()
        return RecordedJob(
            job_id=job_id, name="", status="damaged", total=0, created_at=when,
            updated_at=when, error=reason,
        )  # fmt: skip
