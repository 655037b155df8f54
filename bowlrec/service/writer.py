"""The server's archive writer: group commits sealed and registered in a process of its own.

A server's requests parse, simulate and record their runs in the server process; the group
committer (:class:`~bowlrec.archive.group_commit.GroupCommitter`) then seals each group as a
segment and registers it in the index. In the server's interpreter that last step would share
one core's worth of Python with every request (h5py and sqlite3 hold the GIL for most of their
work), so :class:`WriterProcess` runs it in one child process: the committer thread hands the
group's records over (pickled) and waits, while the server goes on with the next requests.
One writer process serves the whole server, so the archive keeps one writer of index
transactions at a time, as with the committer thread.

The writer starts with the server (:meth:`WriterProcess.start`, in the background) and dies with
it, also when the server is killed (:mod:`bowlrec.batch.lifeline`). When it dies mid-commit
(killed, out of memory), the requests of that group fail
(:class:`~bowlrec.errors.ArchiveWriteError`: their runs may not be archived; a segment it
sealed and did not register is indexed by the next writer, as after any crash, so a run
submitted again may answer ``added: false``) and a new writer process serves the next group.
"""

from __future__ import annotations

import contextlib
import functools
import multiprocessing
import os
import signal
import threading
from concurrent.futures import Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import TYPE_CHECKING

from bowlrec.archive.directory import ArchiveDir
from bowlrec.archive.group_commit import commit_runs
from bowlrec.batch.lifeline import Lifeline, bind_worker, lifeline
from bowlrec.batch.runner import discard_pool, pool_died
from bowlrec.errors import ArchiveWriteError

if TYPE_CHECKING:
    from bowlrec.archive.segment_format import RunRecord

__all__ = ["WriterProcess"]


def _init(line: Lifeline) -> None:
    """In the writer process: Ctrl-C is the server's to handle; die with the server."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    bind_worker(line)


@functools.cache
def _directory(root: str) -> ArchiveDir:
    """In the writer process: the archive directory at ``root``, opened once."""
    return ArchiveDir(root, create=False)


def _open(root: str) -> int:
    """In the writer process: open the archive directory ahead of the first group; its pid."""
    _directory(root)
    return os.getpid()


def _commit(root: str, records: list[RunRecord], durable: bool) -> list[tuple[bool, Path | None]]:
    """In the writer process: :func:`~bowlrec.archive.group_commit.commit_runs`."""
    return commit_runs(_directory(root), records, durable=durable)


#: seconds between checks that the writer process is alive while a group is committed
POLL_S = 0.25


class WriterProcess:
    """Seals and registers groups of runs of the archive ``directory`` in a child process; a
    :data:`~bowlrec.archive.group_commit.Commit` (call it with a group's records).
    ``durable``: fsync each segment."""

    def __init__(self, directory: ArchiveDir, *, durable: bool = True) -> None:
        self.directory = directory
        self.root = str(directory.root)
        self.durable = durable
        self._pool: ProcessPoolExecutor | None = None
        self._closed = False
        self._lock = threading.Lock()

    def _new_pool(self) -> ProcessPoolExecutor:
        # spawn: the server has threads, and a fork server would load the kernels it never uses
        return ProcessPoolExecutor(
            max_workers=1,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init,
            initargs=(lifeline(),),
        )

    def start(self) -> WriterProcess:
        """Start the writer process; it opens the archive in the background (the first group
        waits for that if it comes first)."""
        with self._lock:
            self._started()
        return self

    def _started(self) -> ProcessPoolExecutor | None:
        """The pool, started if needed; None after :meth:`close` (hold ``_lock``)."""
        if self._pool is None and not self._closed:
            self._pool = self._new_pool()
            self._pool.submit(_open, self.root)
        return self._pool

    def __call__(self, records: list[RunRecord]) -> list[tuple[bool, Path | None]]:
        """Commit one group in the writer process (see
        :func:`~bowlrec.archive.group_commit.commit_runs`); raises what the commit raised, or
        :class:`ArchiveWriteError` when the writer process died during it. A writer found dead
        before the group was handed over is replaced and the group handed to the new one.
        After :meth:`close` (a server shutting down), the group is committed in this process."""
        for attempt in range(2):
            with self._lock:  # close() cannot shut the pool down between these two lines
                pool = self._started()
                if pool is None:
                    break
                future = None
                if not pool_died(pool):  # else it died idle: nothing is handed over
                    with contextlib.suppress(BrokenProcessPool):  # the same, as the pool saw it
                        future = pool.submit(_commit, self.root, records, self.durable)
            if future is None:
                self._replace(pool)
                if attempt == 0:
                    continue
                raise ArchiveWriteError(
                    f"{self.root}: the archive's writer process cannot be started"
                ) from None
            return self._result(pool, future, len(records))
        return commit_runs(self.directory, records, durable=self.durable)

    def _result(
        self, pool: ProcessPoolExecutor, future: Future[list[tuple[bool, Path | None]]], n: int
    ) -> list[tuple[bool, Path | None]]:
        """The group's result; ArchiveWriteError when the writer process dies first. The
        process is checked every :data:`POLL_S` s: one killed while sending its result leaves a
        partial message that the pool itself would wait for forever."""
        while True:
            done, _ = wait([future], timeout=POLL_S)
            try:
                if done:
                    return future.result()
                if not pool_died(pool):
                    continue
            except BrokenProcessPool:
                pass
            self._replace(pool)
            raise ArchiveWriteError(
                f"{self.root}: the archive's writer process stopped during a commit of {n} "
                "run(s), which may not be archived: submit them again (one archived meanwhile "
                "answers added: false)"
            ) from None

    def _replace(self, broken: ProcessPoolExecutor) -> None:
        """A new pool for the next group, once; what is left of the broken one is killed."""
        with self._lock:
            if self._pool is not broken:
                return
            self._pool = None
        discard_pool(broken)

    def pid(self) -> int | None:
        """The pid of the writer process now serving (None when there is none: not started,
        closed, or replaced and not started again)."""
        with self._lock:
            pool = self._pool
        if pool is None:
            return None
        return pool.submit(os.getpid).result()

    def close(self) -> None:
        """Stop the writer process once its current group is committed."""
        with self._lock:
            pool, self._pool, self._closed = self._pool, None, True
        if pool is not None:
            pool.shutdown(wait=True)
