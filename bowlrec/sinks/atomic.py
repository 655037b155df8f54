"""Write a file whole or not at all: temporary name, fsync, rename into place, fsync the directory.

A reader (or a process that restarts after ``kill -9``) sees either the previous file or the new
complete one under the final name, never a partial file. Leftover temporaries carry the
``.part`` suffix and a leading dot; :func:`remove_stale_parts` deletes them.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path

__all__ = ["PART_SUFFIX", "atomic_path", "fsync_dir", "remove_stale_parts"]

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
def atomic_path(final: str | os.PathLike[str], *, durable: bool = True) -> Iterator[Path]:
    """Yield a temporary path next to ``final``; on success it is renamed to ``final``.

    The writer inside the ``with`` block must close the file it wrote. On an exception the
    temporary is removed and ``final`` is untouched. ``durable`` fsyncs the file and the
    directory so the rename survives a power loss, not only a killed process.
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{final.name}.{uuid.uuid4().hex[:8]}{PART_SUFFIX}")
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
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def remove_stale_parts(directory: Path) -> int:
    """Delete temporaries left by killed writers under ``directory`` (recursively); the count."""
    n = 0
    for p in directory.rglob(f".*{PART_SUFFIX}"):
        with contextlib.suppress(FileNotFoundError):
            p.unlink()
            n += 1
    return n
