"""``simulate_many``: many deliveries from Python, on the batch engine, returned as a table."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel

from bowlrec.archive import Archive
from bowlrec.batch.job_spec import JobSpec, job_from_mapping, load_job
from bowlrec.batch.runner import run_job
from bowlrec.batch.table import to_arrow, to_numpy
from bowlrec.errors import JobError, MissingExtraError

if TYPE_CHECKING:
    from .runner import ProgressCallback

__all__ = ["simulate_many"]


def _as_job(scenes_or_job: Any) -> tuple[JobSpec, Path]:
    """The job of :func:`simulate_many`'s first argument and the directory its paths are
    relative to; JobError naming what is wrong."""
    if isinstance(scenes_or_job, JobSpec):
        return scenes_or_job, Path(".")
    if isinstance(scenes_or_job, str | Path):
        path = Path(scenes_or_job)
        return load_job(path), path.parent
    if isinstance(scenes_or_job, dict):
        return job_from_mapping(scenes_or_job), Path(".")
    if not isinstance(scenes_or_job, Sequence) or isinstance(scenes_or_job, bytes):
        raise JobError(
            "simulate_many takes a job (JobSpec, mapping or file) or a sequence of scenes, not "
            f"{type(scenes_or_job).__name__}"
        )
    if not scenes_or_job:
        raise JobError("simulate_many: no scenes (the sequence is empty)")
    scenes: list[Any] = []
    for i, s in enumerate(scenes_or_job):
        if isinstance(s, BaseModel):  # a BowlerScene dumps its "format": "bowler"
            scenes.append(s.model_dump(mode="json"))
        elif isinstance(s, dict | str):
            scenes.append(s if isinstance(s, dict) else str(s))
        elif isinstance(s, Path):
            scenes.append(str(s))
        else:
            raise JobError(
                f"scenes[{i}]: a scene must be a Scene, BowlerScene, mapping or path, not "
                f"{type(s).__name__}"
            )
    job = job_from_mapping(
        {
            "name": "simulate_many",
            "sweep": {"kind": "scenes", "scenes": scenes},
            "record": "summary",
        }
    )
    return job, Path(".")


def simulate_many(
    scenes_or_job: JobSpec | dict[str, Any] | str | Path | Sequence[Any],
    *,
    workers: int | None = None,
    archive: Archive | str | Path | None = None,
    output: Literal["arrow", "numpy"] = "arrow",
    chunk_size: int | None = None,
    scheduler: str | None = None,
    progress: ProgressCallback | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """Simulate many deliveries (summary only unless the job records trajectories) and return
    their table.

    ``scenes_or_job``: a :class:`~bowlrec.batch.JobSpec`, a job mapping or file, or a
    sequence of scenes (Scene, BowlerScene, mappings or scene files; each is simulated summary
    only). ``workers``: local processes (None: all cores; 0: this process); ``archive``: an
    :class:`~bowlrec.archive.Archive` or its directory to store the runs in (None: nothing is
    stored). ``output``: "arrow" (a ``pyarrow.Table``, needs ``bowlrec[table]``; absent values
    are null) or "numpy" (a structured array; absent values NaN, -1 or ""). Columns: see
    :mod:`bowlrec.batch.table`. Raises JobError for an invalid job before anything runs.

    >>> from bowlrec import simulate_many
    >>> table = simulate_many("examples/jobs/speed-rev-grid.json", workers=2)  # doctest: +SKIP
    >>> table.column("hook_m")  # doctest: +SKIP
    """

    if output not in ("arrow", "numpy"):
        raise JobError(f"output = {output!r} must be 'arrow' or 'numpy'")
    if workers is not None and (type(workers) is not int or workers < 0):
        raise JobError(f"workers = {workers!r} must be an integer >= 0 (0: this process)")
    if output == "arrow":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise MissingExtraError(
                "simulate_many(output='arrow') needs pyarrow: pip install 'bowlrec[table]', "
                "or pass output='numpy'",
                name="pyarrow",
            ) from None
    job, base_dir = _as_job(scenes_or_job)
    store = None
    if archive is not None:
        store = archive if isinstance(archive, Archive) else Archive(archive)
    result = run_job(
        job,
        store,
        base_dir=base_dir,
        workers=workers,
        scheduler=scheduler,
        chunk_size=chunk_size,
        progress=progress,
        cancel=cancel,
    )
    return to_arrow(result, job) if output == "arrow" else to_numpy(result)
