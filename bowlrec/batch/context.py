"""What a job's workers are handed: how to prepare any run (:class:`JobContext`) and where to
store what they ran (:class:`WriteTarget`). Small, picklable, no imports of the heavy parts."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .job_spec import JobSpec

__all__ = ["JobContext", "WriteTarget"]


@dataclass(frozen=True)
class JobContext:
    """What a worker needs to prepare any run of a job (small and picklable).

    base_*: the validated base scene as a JSON mapping (library ball substituted);
    balls: the library balls the job names ("name" or "name@version" -> (spec mapping,
    "name@version")), resolved by the parent; ball_refs: ball-spec SHA-256 -> newest library
    reference (runs whose ball equals a library spec carry its name); fast_paths: the swept
    paths when :class:`~bowlrec.batch.fastprep.FastSweep` prepares the job, else None.
    """

    key: str
    job: JobSpec
    base_bowler: bool
    base_data: dict[str, Any]
    base_ref: str | None
    base_dir: str
    balls: dict[str, tuple[dict[str, Any], str]]
    ball_refs: dict[str, str]
    fast_paths: tuple[str, ...] | None
    replay_dir: str | None = None
    formats: tuple[str, ...] = ()


@dataclass(frozen=True)
class WriteTarget:
    """Where a worker stores runs: the archive's root; ``mode`` "yes" (write segments),
    "no" (ship records back) or "auto" (write when ``probe`` exists with ``token``: the worker
    sees the archive's filesystem); ``durable`` fsyncs segments."""

    root: str
    mode: str = "yes"
    probe: str | None = None
    token: str | None = None
    durable: bool = True
    #: a file to which a writing worker appends ``index run_id`` lines (fsynced) for the runs
    #: it is about to seal, so the caller can account for a segment sealed just before a kill
    run_log: str | None = None

    def log_runs(self, index: Sequence[int], run_ids: Sequence[str | None]) -> None:
        """Append the runs' lines to :attr:`run_log` (one write, then fsync)."""
        if self.run_log is None:
            return
        text = "".join(f"{i} {r}\n" for i, r in zip(index, run_ids, strict=True) if r)
        fd = os.open(self.run_log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, text.encode("ascii"))
            os.fsync(fd)
        finally:
            os.close(fd)

    def worker_writes(self) -> bool:
        if self.mode != "auto":
            return self.mode == "yes"
        if self.probe is None:
            return False
        try:
            return Path(self.probe).read_text() == self.token
        except OSError:
            return False
