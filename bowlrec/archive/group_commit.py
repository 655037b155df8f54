"""Group commit: many threads each add one run; one thread seals them together.

A server that archives runs one request at a time would write, fsync and register a one-run
segment per request. :class:`GroupCommitter` lets each request thread hand its finished run
over and wait: a committer thread takes every run waiting at that moment, seals them as one
segment and registers it in one index transaction, then wakes their threads. A lone request
waits for one commit (no timer, no batch to fill); under load, the runs that arrive during a
commit go together into the next, so the cost of a commit is shared.

A run is reported archived only after its segment is sealed (fsynced) and registered, as with
:meth:`~bowlrec.archive.Archive.add`. The sealing and registering itself is
:func:`commit_runs`, run in the committer thread or handed to another process (a server's
:class:`~bowlrec.service.writer.WriterProcess`) through the committer's ``commit``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from . import faults
from .directory import ArchiveDir
from .queries import locate, rows
from .writing import new_builder, register, seal

if TYPE_CHECKING:
    from .segment_format import RunRecord

__all__ = ["Commit", "GroupCommitter", "commit_runs"]

#: what seals and registers one group: the runs in, for each run (added by this commit, the
#: path of the segment that holds it, None when it is not archived)
Commit = Callable[[list["RunRecord"]], list[tuple[bool, Path | None]]]


def commit_runs(
    d: ArchiveDir, records: Sequence[RunRecord], *, durable: bool = True
) -> list[tuple[bool, Path | None]]:
    """Seal the runs not archived yet as one segment (``durable``: fsynced) and register it in
    one index transaction; for each run in order: (added by this commit, the path of the
    segment that holds it, None when it is not archived)."""
    found = rows(d, (r.run_id for r in records))
    builder = new_builder()
    mine = {i for i, r in enumerate(records) if r.run_id not in found and builder.append(r)}
    info = None
    if len(builder):
        info = seal(d, builder, durable=durable)
        faults.point("group-commit-sealed", path=info.path)
        register(d, [info])
    out: list[tuple[bool, Path | None]] = []
    for i, r in enumerate(records):
        located = locate(d, r.run_id)
        path = located[2] if located is not None else None
        out.append((i in mine and info is not None and path == info.path, path))
    return out


class _HasDirectory(Protocol):
    """What holds an archive directory (an :class:`~bowlrec.archive.Archive`)."""

    @property
    def directory(self) -> ArchiveDir: ...


@dataclass
class _Waiter:
    record: RunRecord
    done: threading.Event = field(default_factory=threading.Event)
    added: bool = False
    path: Path | None = None
    error: BaseException | None = None


class GroupCommitter:
    """Seals runs added from many threads in shared segments (see the module docs).

    ``archive``: an :class:`~.directory.ArchiveDir` or what holds one (an
    :class:`~bowlrec.archive.Archive`); ``max_runs``: runs per segment at most; ``commit``:
    what seals and registers a group (None: :func:`commit_runs` in the committer thread, which
    fsyncs each segment when ``durable``; a ``commit`` given decides that for itself).
    :meth:`start` starts the committer thread (the first :meth:`add` does if needed);
    :meth:`close` stops it after committing the runs already handed over, and a run added
    later is committed on its own in the calling thread.
    """

    def __init__(
        self,
        archive: ArchiveDir | _HasDirectory,
        *,
        max_runs: int = 1000,
        durable: bool = True,
        commit: Commit | None = None,
    ) -> None:
        self.directory = archive if isinstance(archive, ArchiveDir) else archive.directory
        self.max_runs = max_runs
        self.durable = durable
        self._commit_runs = commit
        self._cond = threading.Condition()
        self._pending: list[_Waiter] = []
        self._closed = False
        self._thread: threading.Thread | None = None
        #: commits that added runs (each one segment) and the runs they added (for monitoring
        #: and tests)
        self.commits = 0
        self.committed_runs = 0

    def start(self) -> GroupCommitter:
        self._thread = threading.Thread(target=self._loop, name="bowlrec-commit", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def add(self, record: RunRecord) -> tuple[bool, Path]:
        """Hand a finished run over and wait until it is archived: (added, segment path).
        ``added`` is False when the run ID was archived already (by another request, or
        before). Raises what the write raised (ArchiveWriteError on a full disk)."""
        waiter = _Waiter(record)
        with self._cond:
            closed = self._closed
            if not closed:
                if self._thread is None:  # not started: start on first use
                    self.start()
                self._pending.append(waiter)
                self._cond.notify()
        if closed:  # after close (a server shutting down): commit this run on its own
            self._commit([waiter])
        waiter.done.wait()
        if waiter.error is not None:
            raise waiter.error
        assert waiter.path is not None
        return waiter.added, waiter.path

    def _loop(self) -> None:
        while True:
            with self._cond:
                while not self._pending and not self._closed:
                    self._cond.wait()
                if not self._pending and self._closed:
                    return
                batch = self._pending[: self.max_runs]
                del self._pending[: self.max_runs]
            self._commit(batch)

    def _commit(self, batch: list[_Waiter]) -> None:
        """Seal and register the batch's runs (those not archived yet) as one segment."""
        records = [w.record for w in batch]
        try:
            if self._commit_runs is None:
                results = commit_runs(self.directory, records, durable=self.durable)
            else:
                results = self._commit_runs(records)
            for w, (added, path) in zip(batch, results, strict=True):
                w.added, w.path = added, path
                if path is None:
                    w.error = RuntimeError(f"run {w.record.run_id} was not archived")
            if any(added for added, _ in results):
                self.commits += 1
                self.committed_runs += sum(1 for added, _ in results if added)
        except BaseException as err:  # the write failed: every waiter of this batch learns it
            for w in batch:
                w.error = err
        for w in batch:
            w.done.set()
