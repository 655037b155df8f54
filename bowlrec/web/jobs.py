"""The archive's jobs as the pages list them, whoever ran them: the service's (``state.jobs``,
:mod:`bowlrec.service.jobs`) and the command line's (``bowlrec batch``, recorded in
``ARCHIVE/jobs/cli/``, :mod:`bowlrec.batch.manifest`), read afresh on each request so a batch
running in another process shows its progress."""

from __future__ import annotations

import builtins
from typing import Any

from bowlrec.batch.manifest import RecordedJobs
from bowlrec.errors import JobNotFoundError

__all__ = ["AllJobs", "all_jobs"]


class AllJobs:
    """``get``, ``list`` and ``spec`` over the service's jobs and the command line's. A
    command-line job has ``source`` "command line" and can be neither cancelled nor resumed
    from the pages (its batch runs in its own process)."""

    def __init__(self, service: Any, archive: Any) -> None:
        self.service = service
        self.recorded = RecordedJobs(archive.root, lambda ids: set(archive.rows(ids)))

    def list(self) -> builtins.list[Any]:
        """Every job, newest first."""
        jobs = [*self.service.list(), *self.recorded.list()]
        return sorted(jobs, key=lambda j: (j.created_at, j.job_id), reverse=True)

    def get(self, job_id: str, with_runs: bool = True) -> Any:
        try:
            return self.service.get(job_id, with_runs=with_runs)
        except JobNotFoundError:
            job = self.recorded.get(job_id, with_runs=with_runs)
            if job is None:
                raise
            return job

    def spec(self, job_id: str) -> Any:
        try:
            return self.service.spec(job_id)
        except JobNotFoundError:
            spec = self.recorded.spec(job_id)
            if spec is None:
                raise
            return spec


def all_jobs(state: Any) -> AllJobs:
    """The jobs of the application state ``state`` (its archive and its job manager)."""
    return AllJobs(state.jobs, state.archive)
