"""Group commit: many threads each add one run; the committer seals them together.

A server that archives runs one request at a time would write, fsync and register a one-run
segment per request. :class:`GroupCommitter` lets each request thread hand its finished run
over and wait: a sealing thread takes every run waiting at that moment and seals them as one
segment; a registering thread registers the segments sealed meanwhile in one index
transaction, then wakes their threads. A lone request waits for one commit (no timer, no batch
to fill); under load, the runs that arrive during a commit go together into the next, so the
cost of a commit is shared, and a segment is written while the one before is registered.

A run is reported archived only after its segment is sealed (fsynced) and registered, as with
:meth:`~bowlrec.archive.Archive.add`.
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from . import faults
from .directory import ArchiveDir
from .queries import locate, rows
from .writing import new_builder, register, seal

if TYPE_CHECKING:
    from .segment_format import RunRecord, SegmentInfo

__all__ = ["GroupCommitter", "RunCommitter"]


class _HasDirectory(Protocol):
    """What holds an archive directory (an :class:`~bowlrec.archive.Archive`)."""

    @property
    def directory(self) -> ArchiveDir: ...


class RunCommitter(Protocol):
    """What archives a finished run and answers (added, segment path) once it is sealed and
    registered: a :class:`GroupCommitter`, or a proxy of one in another process."""

    def add(self, record: RunRecord) -> tuple[bool, Path]: ...


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
    :class:`~bowlrec.archive.Archive`); ``max_runs``: runs per segment at most; ``durable``:
    fsync each segment. :meth:`start` starts the committer threads (the first :meth:`add` does
    if needed); :meth:`close` stops them after committing the runs already handed over, and a
    run added later is committed on its own in the calling thread.

    Two threads share the work: one seals the waiting runs as a segment, the other registers
    the sealed segments (every one sealed meanwhile, in one index transaction) and wakes their
    runs' threads, so the next segment is written while the last one is registered. A run
    whose ID is in a segment sealed and not yet registered is not sealed again: its thread is
    answered once that segment is registered.
    """

    def __init__(
        self, archive: ArchiveDir | _HasDirectory, *, max_runs: int = 1000, durable: bool = True
    ) -> None:
        self.directory = archive if isinstance(archive, ArchiveDir) else archive.directory
        self.max_runs = max_runs
        self.durable = durable
        self._cond = threading.Condition()
        self._pending: list[_Waiter] = []
        self._closed = False
        self._thread: threading.Thread | None = None
        self._registrar: threading.Thread | None = None
        self._sealed: queue.Queue[_Sealed | None] = queue.Queue()
        #: run IDs of segments sealed and not registered yet
        self._in_flight: set[str] = set()
        self._in_flight_lock = threading.Lock()
        #: segments committed and runs in them (for monitoring and tests)
        self.commits = 0
        self.committed_runs = 0

    def start(self) -> GroupCommitter:
        self._registrar = threading.Thread(
            target=self._register_loop, name="bowlrec-register", daemon=True
        )
        self._registrar.start()
        self._thread = threading.Thread(target=self._loop, name="bowlrec-commit", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        for thread in (self._thread, self._registrar):
            if thread is not None:
                thread.join()
        self._thread = self._registrar = None

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
            sealed = self._seal([waiter])
            if sealed is not None:
                self._finish([sealed])
        waiter.done.wait()
        if waiter.error is not None:
            raise waiter.error
        assert waiter.path is not None
        return waiter.added, waiter.path

    def _loop(self) -> None:
        try:
            while True:
                with self._cond:
                    while not self._pending and not self._closed:
                        self._cond.wait()
                    if not self._pending and self._closed:
                        return
                    batch = self._pending[: self.max_runs]
                    del self._pending[: self.max_runs]
                sealed = self._seal(batch)
                if sealed is not None:
                    self._sealed.put(sealed)
        finally:
            self._sealed.put(None)  # the registrar stops after what was sealed

    def _register_loop(self) -> None:
        stop = False
        while not stop:
            item = self._sealed.get()
            items = [] if item is None else [item]
            stop = item is None
            while not stop:  # every segment sealed meanwhile goes in the same transaction
                try:
                    item = self._sealed.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    stop = True
                else:
                    items.append(item)
            if items:
                self._finish(items)

    def _seal(self, batch: list[_Waiter]) -> _Sealed | None:
        """Seal the batch's runs not archived yet and not in flight as one segment (None when
        the write failed: every waiter of the batch has been told)."""
        d = self.directory
        try:
            with self._in_flight_lock:  # before the index is read: see _finish
                in_flight = set(self._in_flight)
            found = rows(d, (w.record.run_id for w in batch))
            builder = new_builder()
            fresh = [
                w
                for w in batch
                if w.record.run_id not in found and w.record.run_id not in in_flight
            ]
            added = [w for w in fresh if builder.append(w.record)]
            info = None
            if len(builder):
                info = seal(d, builder, durable=self.durable)
                faults.point("group-commit-sealed", path=info.path)
                with self._in_flight_lock:
                    self._in_flight.update(w.record.run_id for w in added)
            return _Sealed(batch, info, added, len(builder))
        except BaseException as err:  # the write failed: every waiter of this batch learns it
            _wake(batch, err)
            return None

    def _finish(self, items: list[_Sealed]) -> None:
        """Register the sealed segments in one transaction, then answer their waiters."""
        d = self.directory
        infos = [s.info for s in items if s.info is not None]
        waiters = [w for s in items for w in s.batch]
        try:
            try:
                if infos:
                    register(d, infos)
                    self.commits += len(infos)
                    self.committed_runs += sum(s.runs for s in items)
            finally:  # registered (or failed): a later batch reads the index for these IDs
                with self._in_flight_lock:
                    self._in_flight.difference_update(
                        w.record.run_id for s in items for w in s.added
                    )
            for s in items:
                mine = {id(w) for w in s.added}
                for w in s.batch:
                    located = locate(d, w.record.run_id)
                    w.path = located[2] if located is not None else None
                    w.added = id(w) in mine and s.info is not None and w.path == s.info.path
                    if w.path is None:
                        w.error = RuntimeError(f"run {w.record.run_id} was not archived")
        except BaseException as err:  # the registration failed: every waiter learns it
            _wake(waiters, err)
            return
        _wake(waiters, None)


@dataclass
class _Sealed:
    """A batch whose new runs are sealed as ``info``'s segment (None: nothing new)."""

    batch: list[_Waiter]
    info: SegmentInfo | None
    added: list[_Waiter]
    runs: int


def _wake(waiters: list[_Waiter], error: BaseException | None) -> None:
    for w in waiters:
        if error is not None:
            w.error = error
        w.done.set()
