"""Asynchronous jobs: batch job specs (:mod:`bowlrec.batch`) run into the archive in the background.

A job is a ``bowlrec-job`` spec (a base scene plus sweeps, see :class:`bowlrec.batch.JobSpec`),
or the shorthand ``{"name": ..., "scenes": [...]}`` (a ``scenes`` sweep that keeps each scene's
own ``options``). At submission the job is checked as a whole without expanding it
(:func:`bowlrec.batch.job_context`: base scene, paths, values, library balls, which are frozen
to ``name@version``), then persisted in ``ARCHIVE/jobs/``: ``<id>.spec.json`` (the job; written
once), ``<id>.json`` (the status record, replaced atomically as the job progresses) and
``<id>.runs`` (the run IDs, appended and fsynced by the workers before they seal a chunk and
by this process before it registers one). One background thread runs the jobs in
order on the batch engine, :func:`bowlrec.batch.run_job` (in this process, a local process pool
or a Dask cluster): workers prepare, simulate and seal segments, this process registers them.

A run is visible only once its file is renamed into place and its index row committed, and the
archive is the source of truth for progress: when the server starts, a job that was queued or
running (the server was killed or stopped) is marked ``interrupted`` with ``done`` recomputed
from the archive (its runs that exist). ``resume`` re-queues it; runs already archived are
skipped, never simulated twice, so a finished run is neither lost nor duplicated.

One server per archive runs jobs: the manager holds an exclusive lock on ``jobs/.lock`` for its
lifetime (released by the OS when the process dies).

A bad file never disables the service: records are validated when read (:class:`StoredRecord`),
and a job whose record is missing, truncated or invalid, or whose spec file is missing, is
logged and listed with status ``damaged`` and a one-line reason in ``error``; cancelling or
resuming it is a conflict (409). Job errors and failure rows are reported without server paths.
"""

from __future__ import annotations

import builtins
import fcntl
import json
import logging
import os
import queue
import threading
import time
import uuid
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from bowlrec.archive import Archive
from bowlrec.archive.run_id import RUN_ID_LENGTH
from bowlrec.atomic_files import atomic_path, remove_stale_parts
from bowlrec.batch import BatchProgress, JobSpec, job_context, run_job
from bowlrec.batch.job import MAX_JOB_RUNS, ScenesSweep, freeze_balls
from bowlrec.errors import (
    ArchiveWriteError,
    DamagedError,
    JobConflictError,
    JobNotFoundError,
    JobsLockedError,
    SpecError,
)
from bowlrec.spec import format_validation_error

if TYPE_CHECKING:
    from bowlrec.batch import ChunkTable, JobSpec

from .models import JobFailure, JobStatus, JobStatusName, StoredJobStatus
from .redact import Redactor

__all__ = ["JobConflictError", "JobManager", "JobNotFoundError", "JobsLockedError", "parse_job"]

log = logging.getLogger("bowlrec.service.jobs")

#: statuses after which nothing runs until a resume
FINAL: frozenset[str] = frozenset({"done", "failed", "interrupted", "cancelled"})
#: seconds between progress records written while a job runs (state changes are always written)
PERSIST_INTERVAL_S = 0.5


class _DamagedRecord(DamagedError):
    """A job's files cannot be used: the reason, and the status to list it with."""

    def __init__(self, reason: str, status: JobStatus) -> None:
        super().__init__(reason)
        self.reason, self.status = reason, status


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


def parse_job(body: Any) -> JobSpec:
    """A :class:`~bowlrec.batch.JobSpec` from a request body (the ``scenes`` shorthand
    included); :class:`SpecError` with field-named lines when invalid. Scenes must be inline:
    paths would name files on the server."""

    if not isinstance(body, dict):
        raise SpecError(f"job: expected a JSON object, got {type(body).__name__}")
    if "scenes" in body and "sweep" not in body and "format" not in body:
        extra = sorted(set(body) - {"name", "description", "scenes"})
        if extra:
            raise SpecError(f"{extra[0]}: not allowed with 'scenes' (use a bowlrec-job spec)")
        body = {
            "name": body.get("name", "job"),
            "description": body.get("description", ""),
            "sweep": {"kind": "scenes", "scenes": body["scenes"]},
            "record": "scene",
        }
    try:
        job = JobSpec.model_validate(body)
    except ValidationError as err:
        lines = format_validation_error(err).splitlines()
        raise SpecError("\n".join(_root_as_job(line) for line in lines)) from None
    if isinstance(job.base, str):
        raise SpecError("base: give the base scene inline (a path would name a server file)")
    for b, block in enumerate(job.blocks()):
        if isinstance(block, ScenesSweep):
            for i, entry in enumerate(block.scenes):
                if isinstance(entry, str):
                    raise SpecError(
                        f"sweep[{b}].scenes[{i}]: give the scene inline (a path would name a "
                        "server file)"
                    )
    return job


@dataclass
class JobRecord:
    """The persisted state of one job (``jobs/<id>.json``). ``run_ids`` (one entry per run of
    the job, None until its chunk finished or when it is invalid before simulation) is kept in
    ``jobs/<id>.runs`` instead: lines ``index run_id`` appended, fsynced, before each chunk's
    runs are registered in the index, so the file names every run the archive lists."""

    job_id: str
    name: str
    status: JobStatusName
    total: int
    created_at: str
    updated_at: str
    done: int = 0
    failed: int = 0
    skipped: int = 0
    error: str | None = None
    failures: list[dict[str, Any]] = field(default_factory=list)

    def to_status(
        self, with_runs: bool = False, run_ids: list[str | None] | None = None
    ) -> JobStatus:
        return JobStatus(
            job_id=self.job_id,
            name=self.name,
            status=self.status,
            total=self.total,
            done=self.done,
            failed=self.failed,
            skipped=self.skipped,
            created_at=self.created_at,
            updated_at=self.updated_at,
            error=self.error,
            resumable=self.status in FINAL and self.done < self.total,
            run_ids=run_ids if with_runs else None,
            failures=[JobFailure(**f) for f in self.failures],
        )

    def archived(self, archive: Archive, run_ids: list[str | None]) -> int:
        """Runs of this job that are in the archive (duplicates counted per run)."""
        present = archive.rows(r for r in run_ids if r is not None)
        return sum(1 for r in run_ids if r is not None and r in present)


class StoredRecord(BaseModel):
    """What a job record file must hold (types strict: a record is written by this module, so
    anything else is damage). Unknown keys are ignored (``run_ids`` of older records)."""

    model_config = ConfigDict(extra="ignore", strict=True)

    job_id: str = Field(pattern=r"^[0-9a-f]{1,64}$")
    name: str
    status: StoredJobStatus
    total: int = Field(ge=0, le=MAX_JOB_RUNS)
    created_at: str
    updated_at: str
    done: int = Field(0, ge=0)
    failed: int = Field(0, ge=0)
    skipped: int = Field(0, ge=0)
    error: str | None = None
    failures: list[JobFailure] = Field(default_factory=list)

    def to_record(self) -> JobRecord:
        data = self.model_dump()
        data["failures"] = [f.model_dump() for f in self.failures]
        return JobRecord(**data)


def _reason(err: ValidationError) -> str:
    """A validation error as one line: ``field: message; ...`` (at most three)."""
    parts = []
    for e in err.errors()[:3]:
        loc = ".".join(str(p) for p in e["loc"])
        parts.append(f"{loc}: {e['msg']}" if loc else str(e["msg"]))
    more = len(err.errors()) - 3
    return "; ".join(parts) + (f"; and {more} more" if more > 0 else "")


def _mtime_iso(*paths: Path) -> str:
    for path in paths:
        try:
            return datetime.fromtimestamp(path.stat().st_mtime, UTC).isoformat(
                timespec="milliseconds"
            )
        except OSError:
            continue
    return _now()


class JobManager:
    """Submits, runs (one job at a time, FIFO), cancels, resumes and reports jobs.

    ``workers``: 0 simulates in the job thread of this process, N > 0 in a local process pool
    of N; ``scheduler``: a dask.distributed address (``tcp://host:port``) instead;
    ``chunk_size``: runs per task sent to a worker (None: the batch engine's default; progress
    and cancellation granularity).
    """

    def __init__(
        self,
        archive: Archive,
        *,
        workers: int = 0,
        scheduler: str | None = None,
        chunk_size: int | None = None,
    ) -> None:
        self.archive = archive
        self.workers = workers
        self.scheduler = scheduler
        self.chunk_size = chunk_size
        self.dir = archive.root / "jobs"
        self.dir.mkdir(parents=True, exist_ok=True)
        self._lock_file: IO[str] | None = None
        self._records: dict[str, JobRecord] = {}
        #: jobs whose files are damaged: their status as reported (``damaged``, the reason)
        self._damaged: dict[str, JobStatus] = {}
        self._redact = Redactor(archive.root)
        self._cancel: dict[str, threading.Event] = {}
        self._mutex = threading.Lock()
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None

    # -- life cycle ----------------------------------------------------------------------------

    def open(self) -> None:
        """Take the jobs lock, repair the archive (this server is its writer) and load the
        records, marking unfinished ones interrupted.

        Raises :class:`JobsLockedError` when another live server holds the lock.
        """
        if self._lock_file is not None:
            return
        fh = open(self.dir / ".lock", "a")  # noqa: SIM115 - held for the manager's lifetime
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.close()
            raise JobsLockedError(
                f"another bowlrec server is running the jobs of {self.archive.root}"
            ) from None
        self._lock_file = fh
        remove_stale_parts(self.dir)
        # a server killed between sealing a segment and registering it leaves a segment the
        # index does not list: index it now, before ``done`` is recounted from the index
        repaired = self.archive.recover()
        if any(repaired.values()):
            log.info("archive repaired after an unclean stop: %s", repaired)
        for job_id in self._job_ids_on_disk():
            try:
                rec = self._load(job_id)
            except _DamagedRecord as damaged:
                log.warning("job %s is damaged: %s", job_id, damaged.reason)
                self._damaged[job_id] = damaged.status
                continue
            if rec.status in ("queued", "running"):
                rec.status = "interrupted"
                rec.done = rec.archived(self.archive, self._run_ids(rec))
                rec.updated_at = _now()
                try:
                    self._persist(rec)
                except ArchiveWriteError as err:  # reported as interrupted all the same
                    log.warning("job %s: %s", job_id, err)
            self._records[rec.job_id] = rec

    def _job_ids_on_disk(self) -> builtins.list[str]:
        """IDs of the jobs that have any file in ``jobs/``: a record, a spec or a runs file."""
        ids: set[str] = set()
        for path in self.dir.iterdir():
            name = path.name
            if name.startswith(".") or not path.is_file():
                continue
            for suffix in (".spec.json", ".json", ".runs"):
                if name.endswith(suffix) and len(name) > len(suffix):
                    ids.add(name[: -len(suffix)])
                    break
        return sorted(ids)

    def _load(self, job_id: str) -> JobRecord:
        """The job's validated record; :class:`_DamagedRecord` when it cannot be used."""
        path = self.dir / f"{job_id}.json"
        spec = self._spec_path(job_id)
        where = f"jobs/{job_id}.json"
        try:
            raw = path.read_bytes()
        except FileNotFoundError:
            what = "its spec" if spec.exists() else "only its runs file"
            raise self._damaged_record(
                job_id, f"record {where} is missing ({what} is left)"
            ) from None
        except OSError as err:
            raise self._damaged_record(
                job_id, f"record {where} is unreadable ({err.strerror})"
            ) from None
        try:
            stored = StoredRecord.model_validate_json(raw)
        except ValidationError as err:
            raise self._damaged_record(job_id, f"record {where}: {_reason(err)}", raw) from None
        if stored.job_id != job_id:
            raise self._damaged_record(
                job_id, f"record {where} names another job ({stored.job_id})", raw
            )
        rec = stored.to_record()
        if not spec.exists():
            raise self._damaged_record(
                job_id, f"job spec jobs/{job_id}.spec.json is missing", raw, rec
            )
        return rec

    def _damaged_record(
        self, job_id: str, reason: str, raw: bytes = b"", rec: JobRecord | None = None
    ) -> _DamagedRecord:
        """What is known of a damaged job, for its listing: the record's fields that are
        readable, else the spec's name, else nothing."""
        name, total, created = "", 0, ""
        if rec is not None:
            name, total, created = rec.name, rec.total, rec.created_at
        else:
            try:
                data = json.loads(raw) if raw else None
            except ValueError:
                data = None
            if isinstance(data, dict):
                name = data["name"] if isinstance(data.get("name"), str) else ""
                if type(data.get("total")) is int and 0 <= data["total"] <= MAX_JOB_RUNS:
                    total = data["total"]
                created = data["created_at"] if isinstance(data.get("created_at"), str) else ""
            if not name:
                name = self._spec_name(job_id)
        paths = (self.dir / f"{job_id}.json", self._spec_path(job_id), self._runs_path(job_id))
        created = created or _mtime_iso(*paths)
        status = JobStatus(
            job_id=job_id,
            name=name,
            status="damaged",
            total=total,
            done=rec.done if rec is not None else 0,
            failed=rec.failed if rec is not None else 0,
            skipped=rec.skipped if rec is not None else 0,
            created_at=created,
            updated_at=_mtime_iso(*paths),
            error=self._redact(reason),
            resumable=False,
        )
        return _DamagedRecord(reason, status)

    def _spec_name(self, job_id: str) -> str:
        try:
            data = json.loads(self._spec_path(job_id).read_bytes())
            name = data["job"]["name"]
        except (OSError, ValueError, KeyError, TypeError):
            return ""
        return name if isinstance(name, str) else ""

    def start(self) -> None:
        """Open (if not yet) and start the worker thread."""
        self.open()
        self._thread = threading.Thread(target=self._worker, name="bowlrec-jobs", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 60.0) -> None:
        """Stop after the runs in flight (kept); the running and queued jobs become
        ``interrupted`` (resumable after a restart)."""
        self._stopping.set()
        with self._mutex:
            for event in self._cancel.values():
                event.set()
        self._queue.put(None)
        if self._thread is not None:
            self._thread.join(timeout)
        with self._mutex:
            for rec in self._records.values():
                if rec.status in ("queued", "running"):
                    self._set(rec, "interrupted")
        if self._lock_file is not None:
            self._lock_file.close()
            self._lock_file = None

    # -- requests ------------------------------------------------------------------------------

    def submit(self, body: Any) -> JobStatus:
        """Check a job as a whole (:class:`~bowlrec.errors.SpecError` when it is invalid: a
        :class:`~bowlrec.errors.JobError` for a job wrong as a whole; an invalid combination
        becomes a failure row when it runs), persist it and queue it."""

        job = parse_job(body)
        job = freeze_balls(job, job_context(job, balls=self.archive.balls))
        total = job.count()  # at most MAX_JOB_RUNS: JobSpec checks it
        now = _now()
        rec = JobRecord(
            job_id=uuid.uuid4().hex[:16],
            name=job.name,
            status="queued",
            total=total,
            created_at=now,
            updated_at=now,
        )
        try:
            with atomic_path(self._spec_path(rec.job_id)) as tmp:
                tmp.write_text(json.dumps({"job": job.model_dump(mode="json", by_alias=True)}))
        except OSError as err:
            raise ArchiveWriteError(
                f"could not store the job ({err.strerror or err}); nothing was queued"
            ) from None
        with self._mutex:
            try:
                self._persist(rec)
            except ArchiveWriteError:  # nothing queued: no spec left for a restart to list
                self._spec_path(rec.job_id).unlink(missing_ok=True)
                raise
            self._records[rec.job_id] = rec
            self._cancel[rec.job_id] = threading.Event()
        self._queue.put(rec.job_id)
        return self._status(rec)

    def get(self, job_id: str, with_runs: bool = True) -> JobStatus:
        with self._mutex:
            if job_id in self._damaged:
                return self._damaged[job_id]
            rec = self._record(job_id)
            return self._status(rec, with_runs)

    def list(self) -> builtins.list[JobStatus]:
        """Every job, newest first (without the per-run IDs); damaged ones included."""
        with self._mutex:
            out = [self._status(r) for r in self._records.values()]
            out.extend(self._damaged.values())
        return sorted(out, key=lambda s: (s.created_at, s.job_id), reverse=True)

    def _status(self, rec: JobRecord, with_runs: bool = False) -> JobStatus:
        """The record as reported: its errors without server paths."""
        status = rec.to_status(with_runs, self._run_ids(rec) if with_runs else None)
        if status.error is not None:
            status.error = self._redact(status.error)
        for failure in status.failures:
            failure.error = self._redact(failure.error)
        return status

    def _refuse_damaged(self, job_id: str, verb: str) -> None:
        damaged = self._damaged.get(job_id)
        if damaged is not None:
            raise JobConflictError(
                f"job {job_id} is damaged and cannot be {verb} ({damaged.error}); restore "
                "or remove its files in the archive's jobs/ directory and restart the server"
            )

    def cancel(self, job_id: str) -> JobStatus:
        """Stop a queued or running job after the runs in flight (finished runs stay)."""
        with self._mutex:
            self._refuse_damaged(job_id, "cancelled")
            rec = self._record(job_id)
            if rec.status not in ("queued", "running"):
                raise JobConflictError(
                    f"job {job_id} is {rec.status}; only queued or running jobs can be cancelled"
                )
            self._cancel.setdefault(job_id, threading.Event()).set()
            if rec.status == "queued":
                self._set(rec, "cancelled")
            return self._status(rec)

    def resume(self, job_id: str) -> JobStatus:
        """Queue an interrupted, cancelled or failed job (or a done one with failed runs)
        again; runs already archived are skipped."""
        with self._mutex:
            self._refuse_damaged(job_id, "resumed")
            rec = self._record(job_id)
            if rec.status in ("queued", "running"):
                raise JobConflictError(f"job {job_id} is already {rec.status}")
            if rec.done >= rec.total:
                raise JobConflictError(f"job {job_id} has nothing left to run")
            self._cancel[job_id] = threading.Event()
            self._set(rec, "queued", error=None)
            status = self._status(rec)
        self._queue.put(job_id)
        return status

    # -- the worker ----------------------------------------------------------------------------

    def _worker(self) -> None:
        while not self._stopping.is_set():
            job_id = self._queue.get()
            if job_id is None:
                return
            try:
                self._work_on(job_id)
            except Exception:  # e.g. the disk is full: the next job may still run
                log.exception("job %s could not be run", job_id)

    def _work_on(self, job_id: str) -> None:
        with self._mutex:
            rec = self._records.get(job_id)
            if rec is None or rec.status != "queued":
                return  # cancelled while queued
            self._set(rec, "running")
            cancel = self._cancel.setdefault(job_id, threading.Event())
        try:
            self._run(rec, cancel)
        except Exception as err:  # the job itself broke (unreadable spec, dead cluster)
            log.exception("job %s failed", job_id)
            with self._mutex:
                self._set(rec, "failed", error=f"{type(err).__name__}: {err}")

    def spec(self, job_id: str) -> JobSpec:
        """The job's spec as persisted at submission; JobNotFoundError for an unknown job,
        JobConflictError when its spec file is damaged."""
        with self._mutex:
            if job_id in self._damaged:
                raise JobConflictError(f"job {job_id}: {self._damaged[job_id].error}")
            self._record(job_id)
        try:
            return self._job(job_id)
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise JobConflictError(f"job {job_id}: its spec cannot be read ({err})") from None

    def _job(self, job_id: str) -> JobSpec:
        """The job as persisted at submission (library balls frozen)."""

        return JobSpec.model_validate(json.loads(self._spec_path(job_id).read_text())["job"])

    def _run(self, rec: JobRecord, cancel: threading.Event) -> None:

        last = [0.0]
        failures: builtins.list[dict[str, Any]] = []
        runs_file = open(self._runs_path(rec.job_id), "a", encoding="ascii")  # noqa: SIM115

        def progress(p: BatchProgress) -> None:
            with self._mutex:
                rec.done, rec.failed, rec.skipped = p.done - p.failed, p.failed, p.archived
                if time.monotonic() - last[0] < PERSIST_INTERVAL_S:
                    return  # counts in memory only
                last[0] = time.monotonic()
                rec.updated_at = _now()
                self._persist(rec, durable=False)

        def before_register(table: ChunkTable) -> None:
            """The chunk's run IDs reach the disk before its runs reach the index."""
            lines = [
                f"{int(i)} {rid}\n"
                for i, rid in zip(table.index.tolist(), table.run_id, strict=True)
                if rid is not None
            ]
            runs_file.write("".join(lines))
            runs_file.flush()
            os.fsync(runs_file.fileno())
            failures.extend(
                {
                    "index": int(table.index[i]),
                    "run_id": table.run_id[i],
                    "error": str(table.error[i]),
                }
                for i, status in enumerate(table.status)
                if status == "failed"
            )

        try:
            result = run_job(
                self._job(rec.job_id),
                self.archive,
                workers=self.workers,
                scheduler=self.scheduler,
                chunk_size=self.chunk_size,
                progress=progress,
                cancel=cancel,
                before_register=before_register,
                run_log=self._runs_path(rec.job_id),
                sink=lambda table: None,  # the rows are in the runs file and the failures list
            )
        finally:
            runs_file.close()
        counts = result.counts
        with self._mutex:
            rec.done = counts["ok"] + counts["archived"]
            rec.failed, rec.skipped = counts["failed"], counts["archived"]
            rec.failures = failures
            if result.error is not None:
                self._set(rec, "failed", error=result.error)
            elif self._stopping.is_set() and result.cancelled:
                self._set(rec, "interrupted")
            elif result.cancelled:
                self._set(rec, "cancelled")
            else:
                self._set(rec, "done")

    # -- records (call with the mutex held) ----------------------------------------------------

    def _record(self, job_id: str) -> JobRecord:
        try:
            return self._records[job_id]
        except KeyError:
            raise JobNotFoundError(f"no job {job_id!r}") from None

    def _set(self, rec: JobRecord, status: JobStatusName, **changes: Any) -> None:
        rec.status = status
        for key, value in changes.items():
            setattr(rec, key, value)
        rec.updated_at = _now()
        self._persist(rec)

    def _persist(self, rec: JobRecord, durable: bool = True) -> None:
        try:
            with atomic_path(self.dir / f"{rec.job_id}.json", durable=durable) as tmp:
                tmp.write_text(json.dumps(asdict(rec), indent=1))
        except OSError as err:
            raise ArchiveWriteError(
                f"could not write the record of job {rec.job_id} ({err.strerror or err})"
            ) from None

    def _spec_path(self, job_id: str) -> Path:
        return self.dir / f"{job_id}.spec.json"

    def _runs_path(self, job_id: str) -> Path:
        return self.dir / f"{job_id}.runs"

    def _run_ids(self, rec: JobRecord) -> builtins.list[str | None]:
        """The job's run IDs by index (None: not known yet) from its runs file."""
        ids: builtins.list[str | None] = [None] * rec.total
        try:
            raw = self._runs_path(rec.job_id).read_bytes()
        except OSError:  # none yet (or unreadable: the runs are still in the archive)
            return ids
        text = raw.decode("ascii", errors="replace")
        for line in text.splitlines():
            index, _, rid = line.partition(" ")
            if index.isdigit() and int(index) < rec.total and len(rid) == RUN_ID_LENGTH:
                ids[int(index)] = rid  # a line cut short by a kill is skipped
        return ids


def _root_as_job(line: str) -> str:
    """``scene: ...`` (the root of a validation error) reads ``job: ...`` for a job."""
    return "job" + line.removeprefix("scene") if line.startswith("scene:") else line
