"""Everything a local pool starts dies with the process that started it (Linux; best effort
elsewhere).

A local pool is three kinds of process: the multiprocessing resource tracker and the fork server
(both started by the batch's process, the one running :func:`~bowlrec.batch.run_job`) and the
pool workers, forked by the fork server (so their parent is the fork server, not the batch's
process). When the batch's process is killed (SIGKILL: no clean-up runs), each of them waits for
another:

* the fork server stops when every holder of its "alive" pipe is gone, and every worker holds
  one;
* the resource tracker stops when every holder of its pipe is gone, and every worker holds one;
* a worker waits for its next task forever. Asking whether the batch's pid is alive is not
  enough: a killed process its parent has not reaped yet (a zombie) still answers
  ``kill(pid, 0)``, and a pid is reused.

So here:

* the fork server watches the batch's process (a pidfd, else its parent pid) and exits the
  moment it is gone (:func:`guard_fork_server`, run at preload by :mod:`bowlrec.batch.warm`);
* each worker has the kernel SIGKILL it when the fork server dies (``PR_SET_PDEATHSIG``; this
  needs no GIL, so a worker deep in a compiled kernel dies too) and also watches a pipe whose only
  write end the batch's process holds: end of file means that process is gone, zombie or not
  (:func:`bind_worker`);
* the resource tracker then sees end of file on its pipe and exits by itself.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import select
import signal
import sys
import threading
import time
from multiprocessing.reduction import DupFd
from typing import Any

__all__ = ["Lifeline", "bind_worker", "guard_fork_server", "lifeline"]

#: seconds between checks of the parent pid where there is no pidfd (not Linux >= 5.3)
POLL_S = 0.5

_PR_SET_PDEATHSIG = 1

_lock = threading.Lock()
#: this process's lifeline pipe (read end, write end) and the pid that made it
_pipe: tuple[int, int] | None = None
_owner: int | None = None
#: in a guarded fork server and the workers it forks: the fork server's pid, and in the server
#: the pidfd of the process that started it
_server_pid: int | None = None
_server_fd: int | None = None
#: libc's prctl, looked up once in the fork server (its workers inherit it)
_prctl: Any = None


class Lifeline:
    """The read end of the batch process's lifeline pipe. Pickled to a multiprocessing child,
    its descriptor is duplicated into the child; end of file on it there means the batch's
    process (``pid``, the only holder of the write end) is gone."""

    def __init__(self, fd: int, pid: int) -> None:
        self.fd = fd
        self.pid = pid

    def __reduce__(self) -> tuple[Any, ...]:

        return _rebuild, (DupFd(self.fd), self.pid)


def _rebuild(dup: Any, pid: int) -> Lifeline:
    return Lifeline(dup.detach(), pid)


def lifeline() -> Lifeline:
    """This process's lifeline (made once per process; its write end is never passed on: it is
    close-on-exec and closed in a forked child)."""
    global _pipe, _owner
    with _lock:
        if _pipe is None or _owner != os.getpid():
            _pipe = os.pipe()
            _owner = os.getpid()
        return Lifeline(_pipe[0], _owner)


def _forget_in_child() -> None:
    """After os.fork: the child must not hold the parent's write end (it would keep the
    parent's workers alive after the parent died), nor a fork server's pidfd."""
    global _pipe, _owner, _server_fd
    fds: list[int] = []
    if _pipe is not None and _owner != os.getpid():
        fds += _pipe
        _pipe = _owner = None
    if _server_fd is not None and _server_pid != os.getpid():
        fds.append(_server_fd)
        _server_fd = None
    for fd in fds:
        with contextlib.suppress(OSError):
            os.close(fd)


os.register_at_fork(after_in_child=_forget_in_child)


def _readable(fd: int, timeout: float | None = 0.0) -> bool:
    """True when ``fd`` is readable (or hung up) within ``timeout`` seconds (None: wait): for a
    pipe nobody writes to, end of file; for a pidfd, its process has exited."""
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    ms = None if timeout is None else int(timeout * 1000)
    while True:
        try:
            return bool(poller.poll(ms))
        except InterruptedError:
            continue


def _die() -> None:
    os._exit(1)


# -- pool workers -----------------------------------------------------------------------------


def _libc_prctl() -> Any:
    """libc's prctl (None where there is none)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _set_pdeathsig() -> bool:
    """Ask the kernel to SIGKILL this process when its parent exits (Linux only)."""

    prctl = _prctl or _libc_prctl()
    return prctl is not None and prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0


def bind_worker(line: Lifeline | None) -> None:
    """In a pool worker: die with the fork server and with the batch's process.

    The parent-death signal is tied to the thread that forked this process: it is set only
    under a guarded fork server (whose main thread forks every worker and lives as long as it).
    Either process may already have died before this ran, so both are checked afterwards."""
    if _server_pid is not None:
        _set_pdeathsig()
        if os.getppid() != _server_pid:  # the fork server died before prctl
            _die()
    if line is None:
        return
    if _readable(line.fd):  # the batch's process died before we got here
        _die()

    def watch() -> None:
        while True:
            try:
                if os.read(line.fd, 1) == b"":
                    break
            except InterruptedError:
                continue
            except OSError:
                break
        _die()

    threading.Thread(target=watch, name="bowlrec-lifeline", daemon=True).start()


# -- the fork server --------------------------------------------------------------------------


def _fork_server_frame() -> Any:
    """The frame of multiprocessing.forkserver.main when we are being preloaded by it."""
    forkserver = sys.modules.get("multiprocessing.forkserver")
    main = getattr(forkserver, "main", None)
    code = getattr(main, "__code__", None)
    if code is None:
        return None
    frame: Any = sys._getframe(1)
    while frame is not None:
        if frame.f_code is code:
            return frame
        frame = frame.f_back
    return None


def _holds_pipe(pid: int, fd: int) -> bool | None:
    """Whether process ``pid`` holds a descriptor of the pipe ``fd`` belongs to (None: cannot
    tell, e.g. no /proc)."""
    try:
        target = f"pipe:[{os.fstat(fd).st_ino}]"
        names = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return None
    for name in names:
        with contextlib.suppress(OSError):
            if os.readlink(f"/proc/{pid}/fd/{name}") == target:
                return True
    return False


def guard_fork_server() -> None:
    """In a multiprocessing fork server (called while it preloads its modules): exit as soon as
    the process that started it is gone. Does nothing in any other process.

    The fork server is the batch process's own child, so that process is our parent until it
    dies; then we are re-parented (to init, or to a subreaper). Our parent is the batch's process
    only if it holds the other end of our "alive" pipe (end of file on that pipe is no proof of
    life or death: a fork request the dead process left queued still carries its end)."""
    global _server_pid, _server_fd, _prctl
    frame = _fork_server_frame()
    if frame is None:
        return
    alive_r = frame.f_locals.get("alive_r")
    del frame
    parent = os.getppid()
    pidfd = None
    if hasattr(os, "pidfd_open"):
        try:
            pidfd = os.pidfd_open(parent)
        except OSError:
            pidfd = None
    # the pidfd was opened before these checks, so if the parent passes them it is the process
    # the pidfd watches. (Our parent may be pid 1: bowlrec itself in a container without an
    # init process. A batch process that died before this ran no longer holds the pipe.)
    if isinstance(alive_r, int) and (_readable(alive_r) or _holds_pipe(parent, alive_r) is False):
        _die()  # the batch's process is gone already
    _server_pid, _server_fd, _prctl = os.getpid(), pidfd, _libc_prctl()

    def watch() -> None:
        if pidfd is not None:
            _readable(pidfd, None)
        else:
            while os.getppid() == parent:
                time.sleep(POLL_S)
        _die()

    threading.Thread(target=watch, name="bowlrec-lifeline", daemon=True).start()
