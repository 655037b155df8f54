"""Write a file whole or not at all: temporary name, fsync, rename into place, fsync the directory.

A reader (or a process that restarts after ``kill -9``) sees either the previous file or the new
complete one under the final name, never a partial file. Leftover temporaries carry the
``.part`` suffix and a leading dot; :func:`remove_stale_parts` deletes them. With
``hold_lock`` the writer holds an exclusive ``flock`` on its temporary until it is renamed, so a
cleanup running in another process never deletes a temporary that is still being written.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

__all__ = ["PART_SUFFIX", "atomic_path", "fsync_dir", "remove_stale_parts", "unlocked"]

PART_SUFFIX = ".part"


def fsync_dir(directory: Path) -> None:
    """Flush a directory entry (a rename) to disk; a no-op where directories cannot be opened."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(
    final: str | os.PathLike[str], *, durable: bool = True, hold_lock: bool = False
) -> Iterator[Path]:
    """Yield a temporary path next to ``final``; on success it is renamed to ``final``.

    The writer inside the ``with`` block must close the file it wrote. On an exception the
    temporary is removed and ``final`` is untouched. ``durable`` fsyncs the file and the
    directory so the rename survives a power loss, not only a killed process. The temporary
    is created (empty) before the block runs, so a directory that cannot be written raises
    ``OSError`` naming ``final``; the writer opens it for writing and truncates it.
    ``hold_lock`` holds an exclusive flock on it until the rename (see
    :func:`remove_stale_parts`).
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{final.name}.{uuid.uuid4().hex[:8]}{PART_SUFFIX}")
    try:  # created here, so that a place that cannot be written fails naming ``final``
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    except OSError as err:
        err.filename = str(final)
        raise
    lock_fd = -1  # the descriptor whose flock is held until the rename
    if hold_lock:
        fcntl.flock(fd, fcntl.LOCK_EX)
        lock_fd = fd
    else:
        os.close(fd)
    try:
        yield tmp
        if durable:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, final)
        if durable:
            fsync_dir(final.parent)
    except BaseException as err:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if isinstance(err, OSError) and err.filename == str(tmp):
            err.filename = str(final)  # name the file the caller asked for, not its temporary
        raise
    finally:
        if lock_fd >= 0:
            os.close(lock_fd)


def unlocked(path: Path) -> bool:
    """True when no process holds a flock on ``path`` (a killed writer's lock is gone)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)
    return True


def remove_stale_parts(directory: Path, *, min_age_s: float = 0.0) -> int:
    """Delete temporaries left by killed writers under ``directory`` (recursively); the count.

    A temporary younger than ``min_age_s`` seconds, or locked by its writer (``hold_lock``),
    is left alone: it may belong to a writer that is still running.
    """
    n = 0
    now = time.time()
    for p in directory.rglob(f".*{PART_SUFFIX}"):
        with contextlib.suppress(FileNotFoundError):
            if min_age_s > 0 and now - p.stat().st_mtime < min_age_s:
                continue
            if not unlocked(p):
                continue
            p.unlink()
            n += 1
    return n
