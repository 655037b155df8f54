"""Generated blocks of a Markdown file, between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``
lines (the README's tables that tools rewrite and tests compare with what they compute)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["read_block", "replace_block"]


def _markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}:begin -->\n", f"<!-- {name}:end -->\n"


def read_block(path: str | Path, name: str) -> str:
    """The text between the block's marker lines (ValueError if a marker is missing)."""
    begin, end = _markers(name)
    text = Path(path).read_text(encoding="utf-8")
    return text[text.index(begin) + len(begin) : text.index(end)]


def replace_block(path: str | Path, name: str, content: str) -> bool:
    """Put ``content`` between the block's marker lines; True when the file changed."""
    begin, end = _markers(name)
    p = Path(path)
    text = p.read_text(encoding="utf-8")
    new = text[: text.index(begin) + len(begin)] + content + text[text.index(end) :]
    if new == text:
        return False
    p.write_text(new, encoding="utf-8")
    return True
