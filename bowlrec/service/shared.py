"""What the processes of one server share, and the channel to the process that holds it.

A server of several processes (``bowlrec serve --workers N``) has one supervisor process that
holds what must exist once per archive: the group committer (the one writer of summary-only
runs), the jobs (their lock, queue and runner) and the cookie sessions. Its worker processes
serve HTTP and simulate; they call these objects through :class:`WriterClient`, one
connection per thread over a Unix socket in a directory only this user can enter, with a
random key checked when a connection opens (:mod:`multiprocessing.connection`).

A call carries the method name and its arguments (pickled); the answer is the return value or
the exception, raised again in the caller. Only the methods in :data:`METHODS` can be called.
When the supervisor does not answer (it is gone, or stopping) a call raises
:class:`WriterGoneError` (503 with ``Retry-After``).
"""

from __future__ import annotations

import contextlib
import logging
import os
import pickle
import secrets
import shutil
import socket
import tempfile
import threading
from dataclasses import dataclass
from multiprocessing.connection import Client, Connection, Listener
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from bowlrec.errors import BusyError

if TYPE_CHECKING:
    from bowlrec.archive.segment_format import RunRecord
    from bowlrec.batch import JobSpec

    from .models import JobStatus

__all__ = [
    "METHODS",
    "Jobs",
    "Sessions",
    "Shared",
    "WriterClient",
    "WriterGoneError",
    "WriterService",
]

log = logging.getLogger(__name__)

#: the methods a worker may call on each shared object
METHODS: dict[str, frozenset[str]] = {
    "commits": frozenset({"add"}),
    "jobs": frozenset({"submit", "get", "list", "cancel", "resume", "spec"}),
    "sessions": frozenset({"open", "valid", "close"}),
}


class WriterGoneError(BusyError):
    """The server's supervisor process (the archive's writer) did not answer: it is stopping
    or gone. A run submitted meanwhile may or may not be archived; submitting it again is
    safe (an archived run answers ``added: false``)."""


class Committer(Protocol):
    """What seals a summary-only run (:class:`~bowlrec.archive.group_commit.GroupCommitter`)."""

    def start(self) -> Any: ...

    def close(self) -> None: ...

    def add(self, record: RunRecord) -> tuple[bool, Path]: ...


class Jobs(Protocol):
    """What the endpoints and the pages use of :class:`~bowlrec.service.jobs.JobManager`."""

    def open(self) -> None: ...

    def start(self) -> None: ...

    def stop(self, timeout: float = 60.0) -> None: ...

    def submit(self, body: Any) -> JobStatus: ...

    def get(self, job_id: str, with_runs: bool = True) -> JobStatus: ...

    def list(self) -> list[JobStatus]: ...

    def cancel(self, job_id: str) -> JobStatus: ...

    def resume(self, job_id: str) -> JobStatus: ...

    def spec(self, job_id: str) -> JobSpec: ...


class Sessions(Protocol):
    """What the endpoints use of :class:`~bowlrec.service.security.SessionStore`."""

    ttl_s: float

    def open(self) -> tuple[str, float]: ...

    def valid(self, session_id: str | None) -> bool: ...

    def close(self, session_id: str | None) -> bool: ...


@dataclass(frozen=True)
class Shared:
    """The objects an application of a worker process uses instead of its own."""

    commits: Committer
    jobs: Jobs
    sessions: Sessions


# -- the supervisor's side -----------------------------------------------------------------------


def _portable(err: BaseException) -> BaseException:
    """``err`` if it survives pickling, else the nearest class of its kind with its message
    (the category, hence the HTTP status, is kept)."""
    for kind in type(err).__mro__:
        if not issubclass(kind, BaseException):
            continue
        try:
            candidate = err if kind is type(err) else kind(str(err))
            pickle.loads(pickle.dumps(candidate))
        except Exception:  # noqa: BLE001, S112 - try the next class up
            continue
        return candidate
    return RuntimeError(str(err))  # pragma: no cover - BaseException(str) always pickles


class WriterService:
    """Answers the worker processes' calls on ``objects`` (name -> object, the names of
    :data:`METHODS`), one thread per connection. :attr:`address` and :attr:`authkey` are what a
    :class:`WriterClient` needs; :meth:`close` stops accepting and removes the socket."""

    def __init__(self, objects: dict[str, Any]) -> None:
        self.objects = objects
        self.authkey = secrets.token_bytes(32)
        self._dir = tempfile.mkdtemp(prefix="bowlrec-writer-")  # mode 0700
        self.address = os.path.join(self._dir, "writer.sock")
        self._listener = Listener(self.address, family="AF_UNIX", authkey=self.authkey)
        self._closed = threading.Event()
        self._conns: set[Connection] = set()
        self._conns_lock = threading.Lock()
        self._thread = threading.Thread(target=self._accept, name="bowlrec-writer", daemon=True)
        self._thread.start()

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                conn = self._listener.accept()
            except OSError:  # closed
                return
            except Exception as err:  # noqa: BLE001 - a connection without the key: refused
                log.warning("refused a connection to the writer: %s", err)
                continue
            threading.Thread(
                target=self._serve, args=(conn,), name="bowlrec-writer-conn", daemon=True
            ).start()

    def _serve(self, conn: Connection) -> None:
        with self._conns_lock:
            self._conns.add(conn)
        with conn:
            while not self._closed.is_set():
                try:
                    name, method, args, kwargs = conn.recv()
                except (EOFError, OSError):  # the worker closed it (or exited)
                    return
                try:
                    if method not in METHODS.get(name, ()):
                        raise AttributeError(f"{name}.{method} cannot be called by a worker")
                    answer: tuple[str, Any] = (
                        "ok",
                        getattr(self.objects[name], method)(*args, **kwargs),
                    )
                except BaseException as err:  # noqa: BLE001 - raised again in the worker
                    answer = ("err", _portable(err))
                try:
                    conn.send(answer)
                except (OSError, ValueError):  # the worker is gone
                    break
        with self._conns_lock:
            self._conns.discard(conn)

    def close(self) -> None:
        """Stop answering: no new connection, and the open ones are shut (a call in
        progress still gets its answer if it is ready first)."""
        self._closed.set()
        with contextlib.suppress(OSError):
            self._listener.close()
        with self._conns_lock:
            conns = list(self._conns)
        for conn in conns:  # wakes the threads waiting for their worker's next call
            with contextlib.suppress(OSError, ValueError):
                sock = socket.socket(fileno=conn.fileno())
                try:
                    sock.shutdown(socket.SHUT_RDWR)
                finally:
                    sock.detach()
        shutil.rmtree(self._dir, ignore_errors=True)


# -- the workers' side ---------------------------------------------------------------------------


class WriterClient:
    """Calls the supervisor's shared objects: one connection per thread, opened on first use."""

    def __init__(self, address: str, authkey: bytes) -> None:
        self.address = address
        self.authkey = authkey
        self._local = threading.local()

    def call(self, name: str, method: str, *args: Any, **kwargs: Any) -> Any:
        conn: Connection | None = getattr(self._local, "conn", None)
        try:
            if conn is None:
                conn = Client(self.address, family="AF_UNIX", authkey=self.authkey)
                self._local.conn = conn
            conn.send((name, method, args, kwargs))
            status, value = conn.recv()
        except (EOFError, OSError):
            self._local.conn = None
            if conn is not None:
                with contextlib.suppress(OSError):
                    conn.close()
            raise WriterGoneError(
                "the server's writer process is not answering (the server is stopping, or its "
                "supervisor process is gone); try again: a run already archived answers "
                "added: false"
            ) from None
        if status == "err":
            raise value
        return value

    def shared(self, session_ttl_s: float) -> Shared:
        """The proxies of the supervisor's objects for :func:`~bowlrec.service.app.create_app`."""
        return Shared(
            commits=_RemoteCommitter(self),
            jobs=_RemoteJobs(self),
            sessions=_RemoteSessions(self, session_ttl_s),
        )


class _RemoteCommitter:
    def __init__(self, client: WriterClient) -> None:
        self._client = client

    def start(self) -> _RemoteCommitter:
        return self  # the supervisor's committer runs already

    def close(self) -> None:
        """Nothing to do: the supervisor commits what its workers handed over."""

    def add(self, record: RunRecord) -> tuple[bool, Path]:
        added, path = self._client.call("commits", "add", record)
        return bool(added), Path(path)


class _RemoteJobs:
    def __init__(self, client: WriterClient) -> None:
        self._call = client.call

    def open(self) -> None:
        """The supervisor holds the jobs lock."""

    def start(self) -> None:
        """The supervisor runs the jobs."""

    def stop(self, timeout: float = 60.0) -> None:
        """The supervisor stops the jobs."""

    def submit(self, body: Any) -> JobStatus:
        status: JobStatus = self._call("jobs", "submit", body)
        return status

    def get(self, job_id: str, with_runs: bool = True) -> JobStatus:
        status: JobStatus = self._call("jobs", "get", job_id, with_runs)
        return status

    def list(self) -> list[JobStatus]:
        statuses: list[JobStatus] = self._call("jobs", "list")
        return statuses

    def cancel(self, job_id: str) -> JobStatus:
        status: JobStatus = self._call("jobs", "cancel", job_id)
        return status

    def resume(self, job_id: str) -> JobStatus:
        status: JobStatus = self._call("jobs", "resume", job_id)
        return status

    def spec(self, job_id: str) -> JobSpec:
        spec: JobSpec = self._call("jobs", "spec", job_id)
        return spec


class _RemoteSessions:
    def __init__(self, client: WriterClient, ttl_s: float) -> None:
        self._call = client.call
        self.ttl_s = ttl_s

    def open(self) -> tuple[str, float]:
        session_id, expires = self._call("sessions", "open")
        return str(session_id), float(expires)

    def valid(self, session_id: str | None) -> bool:
        return bool(self._call("sessions", "valid", session_id))

    def close(self, session_id: str | None) -> bool:
        return bool(self._call("sessions", "close", session_id))
