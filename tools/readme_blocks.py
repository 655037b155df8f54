"""Generated blocks of a Markdown file, between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``
lines: the tables of README.md and docs/*.md that scripts rewrite and tests compare with what
they compute (which block is in which page: :data:`BLOCKS`)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["BLOCKS", "ROOT", "block_path", "read_block", "replace_block"]

#: the repository's root
ROOT = Path(__file__).resolve().parents[1]

#: every generated block, by name: the page that holds it (relative to the root) and what
#: writes it
BLOCKS: dict[str, tuple[str, str]] = {
    "pipeline-headline": ("README.md", "python -m benchmarks.pipeline --update-docs"),
    "pipeline-targets": ("docs/pipeline.md", "python -m benchmarks.pipeline --update-docs"),
    "archive-targets": ("docs/archive-format.md", "benchmarks/results/archive.md, by hand"),
    "formats": ("docs/replay.md", "python -m benchmarks.formats --update-docs"),
    "bench": ("docs/performance.md", "python -m benchmarks.work_precision --update-docs"),
    "stress": ("docs/validation.md", "python -m benchmarks.stress --update-docs"),
    "table3": ("docs/validation.md", "python -m tools.update_table3"),
    "table2": ("docs/bowlers.md", "python examples/table2_sweep.py --update-docs"),
    "coverstock": ("docs/coverstock.md", "python benchmarks/coverstock_sensitivity.py"),
    "layers": ("docs/architecture.md", "python -m tools.layers --update-docs"),
}


def block_path(name: str) -> Path:
    """The page that holds the generated block ``name``."""
    return ROOT / BLOCKS[name][0]


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
