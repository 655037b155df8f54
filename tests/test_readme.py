"""The README's commands run as written, and the links of README.md and docs/*.md resolve.

Every ```bash, ```sh, ```console (its ``$ `` lines) and ```python block of README.md is one test,
run in README order in a fresh ``bash -e`` with the venv's ``bin`` first on PATH (what
``source .venv/bin/activate`` does). The blocks share a working directory that holds copies of
the files they read (``examples/``, ``benchmarks/jobs/``), so the files they write never touch the
repository, and HOME and BOWLREC_ARCHIVE point into it, so nothing touches the user's archive or
configuration. A block whose preceding line is ``<!-- readme-test: skip (REASON) -->`` (it
installs, needs a display or a running server) is reported as skipped with that reason. Running
one block alone (``-k``) runs the blocks before it first.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: what the README's commands read, copied into the working directory
INPUTS = ("examples", "benchmarks/jobs")
SHELLS = {"bash", "sh", "console"}
SKIP = re.compile(r"<!--\s*readme-test:\s*skip\s*\((?P<reason>.+)\)\s*-->")
#: the README stays a product page
MAX_README_LINES = 250


@dataclass(frozen=True)
class Block:
    index: int
    line: int  # 1-based line of the opening fence
    lang: str
    script: str  # what bash runs
    first: str  # the first command, for the test ID
    skip: str | None  # the reason, when marked


def _commands(lang: str, body: list[str]) -> list[str]:
    """The lines bash runs: a console block's ``$ `` lines (with their ``\\`` continuations)."""
    if lang != "console":
        return body
    out: list[str] = []
    continued = False
    for line in body:
        if line.startswith("$ "):
            out.append(line[2:])
        elif continued:
            out.append(line)
        else:
            continue
        continued = line.rstrip().endswith("\\")
    return out


def readme_blocks(path: Path = README) -> list[Block]:
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        fence = re.fullmatch(r"```(\w+)\s*", lines[i])
        if fence is None:
            if lines[i].startswith("```"):  # a fence of another kind: skip to its end
                i += 1
                while i < len(lines) and not lines[i].startswith("```"):
                    i += 1
            i += 1
            continue
        lang = fence.group(1)
        start = i
        i += 1
        body: list[str] = []
        while lines[i].rstrip() != "```":
            body.append(lines[i])
            i += 1
        i += 1
        if lang not in SHELLS | {"python"}:
            continue
        prev = next((lines[k] for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        marker = SKIP.search(prev)
        if lang == "python":
            script = "python - <<'README_PYTHON'\n" + "\n".join(body) + "\nREADME_PYTHON\n"
            first = "python " + next(ln for ln in body if ln.strip() and not ln.startswith("#"))
        else:
            commands = _commands(lang, body)
            script = "\n".join(commands) + "\n"
            first = next(c for c in commands if c.strip() and not c.lstrip().startswith("#"))
        blocks.append(
            Block(
                index=len(blocks),
                line=start + 1,
                lang=lang,
                script=script,
                first=first.split("#")[0].strip(),
                skip=marker.group("reason") if marker else None,
            )
        )
    return blocks


BLOCKS = readme_blocks()


def _block_id(block: Block) -> str:
    words = re.sub(r"[^\w./=$&-]+", "", re.sub(r"\s+", "_", block.first))
    return f"{block.index:02d}-{words[:64]}"


@dataclass
class Tour:
    """The shared working directory and environment, and which blocks have run in it."""

    cwd: Path
    env: dict[str, str]
    done: set[int] = field(default_factory=set)

    def run(self, block: Block) -> subprocess.CompletedProcess[str]:
        for earlier in BLOCKS[: block.index]:  # what this block relies on (files, runs)
            if earlier.skip is None and earlier.index not in self.done:
                self._run(earlier)
        return self._run(block)

    def _run(self, block: Block) -> subprocess.CompletedProcess[str]:
        proc = subprocess.run(
            ["bash", "-e", "-o", "pipefail", "-c", block.script],
            cwd=self.cwd,
            env=self.env,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        self.done.add(block.index)
        assert proc.returncode == 0, (
            f"README.md line {block.line}: exit status {proc.returncode}\n"
            f"--- script\n{block.script}--- stdout\n{proc.stdout[-4000:]}\n"
            f"--- stderr\n{proc.stderr[-4000:]}"
        )
        return proc


@pytest.fixture(scope="module")
def tour(tmp_path_factory: pytest.TempPathFactory) -> Tour:
    base = tmp_path_factory.mktemp("readme")
    cwd = base / "bowlrec"
    for name in INPUTS:
        shutil.copytree(
            ROOT / name, cwd / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc")
        )
    home = base / "home"
    home.mkdir()
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("BOWLREC_", "XDG_", "PYTHON", "VIRTUAL_ENV", "MPL"))
    }
    venv_bin = Path(sys.executable).parent
    env.update(
        PATH=f"{venv_bin}{os.pathsep}{env.get('PATH', '')}",
        VIRTUAL_ENV=str(venv_bin.parent),
        HOME=str(home),
        BOWLREC_ARCHIVE=str(base / "archive"),
        MPLBACKEND="Agg",
    )
    return Tour(cwd=cwd, env=env)


def test_readme_has_runnable_blocks() -> None:
    assert len([b for b in BLOCKS if b.skip is None]) >= 5
    assert len(README.read_text(encoding="utf-8").splitlines()) <= MAX_README_LINES


@pytest.mark.process
@pytest.mark.parametrize("block", BLOCKS, ids=_block_id)
def test_readme_block_runs(block: Block, tour: Tour) -> None:
    if block.skip is not None:
        pytest.skip(block.skip)
    tour.run(block)


# --- links ------------------------------------------------------------------------------------

PAGES = [README, *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def _prose(text: str) -> str:
    """The text without fenced code blocks and inline code spans."""
    text = re.sub(r"^```.*?^```[ \t]*$", "", text, flags=re.S | re.M)
    return re.sub(r"`[^`\n]*`", "", text)


def _anchors(path: Path) -> set[str]:
    """GitHub's heading anchors of a Markdown file (the heading's text, inline code included,
    lowercased, without punctuation but ``-`` and ``_``, spaces as ``-``; repeats get ``-1``...)."""
    text = re.sub(r"^```.*?^```[ \t]*$", "", path.read_text(encoding="utf-8"), flags=re.S | re.M)
    anchors: set[str] = set()
    for line in text.splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m is None:
            continue
        heading = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", m.group(1))  # a link: its text
        heading = re.sub(r"[`*]", "", heading).strip().lower()
        anchor = re.sub(r"[^\w\- ]", "", heading).replace(" ", "-")
        base, n = anchor, 1
        while anchor in anchors:
            anchor, n = f"{base}-{n}", n + 1
        anchors.add(anchor)
    return anchors


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page: Path) -> None:
    broken: list[str] = []
    for target in LINK.findall(_prose(page.read_text(encoding="utf-8"))):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        dest = (page.parent / path_part).resolve() if path_part else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(f"{target}: no heading #{anchor} in {dest.relative_to(ROOT)}")
    assert not broken, f"{page.relative_to(ROOT)}: " + "; ".join(broken)
