"""Filesystem paths out of what the service answers.

Error details, job errors and failure rows are built from exception messages, which often name
files (the archive's root, a segment, a temporary). :class:`Redactor` rewrites them before they
leave the server: the archive's root becomes ``ARCHIVE`` (``no run 'x' in archive ROOT`` loses
the ``in archive ROOT`` part) and any other absolute path becomes ``<path>``. Every line is
also made printable (:func:`bowlrec.spec.errors.printable`: control characters escaped, long
lines cut), since messages can quote what a client sent.
"""

from __future__ import annotations

import contextlib
import os
import re
from pathlib import Path

__all__ = ["Redactor"]

#: an absolute POSIX path: '/' then characters that are not space, quotes or punctuation that
#: ends a path in a message; not preceded by a word character (``a/b``, ``ARCHIVE/x``, URLs)
_ABSOLUTE = re.compile(r"(?<![\w.~/:-])/[^\s'\"`,;:()\[\]{}<>]+")


class Redactor:
    """``redactor(text)``: ``text`` without the archive's root or other absolute paths, every
    line printable."""

    def __init__(self, root: str | os.PathLike[str] | None = None) -> None:
        roots: set[str] = set()
        if root is not None:
            path = Path(root)
            roots.add(str(path))
            roots.add(str(path.absolute()))
            with contextlib.suppress(OSError, RuntimeError):  # a loop of symlinks
                roots.add(str(path.resolve()))
        #: longest first, so a root that contains another is replaced whole
        self._roots = sorted((r for r in roots if r not in ("", "/", ".")), key=len, reverse=True)

    def __call__(self, text: str) -> str:
        for root in self._roots:
            if root.startswith("/"):
                text = text.replace(f" in archive {root}", "")
                text = text.replace(f" of {root}", " of the archive")
                text = re.sub(re.escape(root) + r"(?=/|\b|$)", "ARCHIVE", text)
            else:  # a relative root ("data") is a path only where a "/" follows it
                text = re.sub(r"(?<![\w./-])" + re.escape(root) + r"(?=/)", "ARCHIVE", text)
        from bowlrec.spec.errors import printable

        text = _ABSOLUTE.sub(_path_or_text, text)
        return "\n".join(printable(line) for line in text.split("\n"))


def _path_or_text(match: re.Match[str]) -> str:
    """``<path>`` when the match looks like a filesystem path: two or more components, the
    first an entry of ``/`` (``/tmp/x``, ``/home/u/a``), or three or more components."""
    text = match.group(0)
    parts = [p for p in text.split("/") if p]
    if len(parts) >= 3 or (len(parts) >= 2 and os.path.lexists("/" + parts[0])):
        return "<path>"
    return text
