"""The README's commands run as written, and the links of README.md and docs/*.md resolve.

Every ```bash, ```sh, ```console (its ``$ `` lines) and ```python block of README.md is one test,
run in README order in a fresh ``bash -e`` with the venv's ``bin`` first on PATH (what
``source .venv/bin/activate`` does). The blocks share a working directory that holds copies of
the files they read (``examples/``, ``benchmarks/jobs/``), so the files they write never touch the
repository, and HOME and BOWLREC_ARCHIVE point into it, so nothing touches the user's archive or
configuration. A block whose preceding line is ``<!-- readme-test: skip (REASON) -->`` (it
installs, needs a display or a running server) is reported as skipped with that reason. Running
one block alone (``-k``) runs the blocks before it first.

A ```console block also shows what its commands print: the lines after a ``$`` command, up to
the next one, must appear in that order in what the command prints (its stdout, then its
stderr); a line that is ``...`` stands for omitted lines and ``...`` inside a line for omitted
text. Everything else is compared exactly, numbers included (seeds are fixed), after
:func:`normalized` replaces what legitimately varies (the archive's path and :data:`VARIES`:
timestamps, elapsed times, throughputs, and what depends on the CPU: run IDs and the last digits
of a float printed in full) and collapses the padding of table cells (their widths follow the
longest cell, e.g. the archive's path). To tell the commands' outputs
apart, the block's script prints a marker line before each command (to stdout and stderr); the
commands themselves run as before, in one ``bash -e`` per block.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
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
#: printed before each command of a console block (stdout and stderr) to split their outputs
MARK = "@@bowlrec-readme-test command "
#: the archive's path as README.md shows it (the default under a user's HOME)
README_ARCHIVE = "/home/you/.local/share/bowlrec/archive"
#: what legitimately differs between README.md and a run, replaced on both sides before the
#: comparison (the archive's path is replaced first, by :func:`normalized`)
VARIES: tuple[tuple[re.Pattern[str], str | Callable[[re.Match[str]], str]], ...] = (
    # timestamps: "2026-11-27 17:06:29", "2026-11-27T17:06:29.228278+00:00"
    (
        re.compile(r"\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}:\d{2}(?:\.\d+)?(?:[+-]\d{2}:\d{2}|Z)?"),
        "<TIME>",
    ),
    # elapsed time: "(20 simulated in 5.3 s)", "31 shots in 315 ms"
    (re.compile(r"\bin \d+(?:\.\d+)? (?:s|ms)\b"), "in <ELAPSED>"),
    # throughput: "16,054 runs/s", "33,153 deliveries/s"
    (re.compile(r"\b[\d,]+(?:\.\d+)? (runs|deliveries|shots)/s\b"), r"<RATE> \1/s"),
    # run IDs (20 hex digits, or their first 10 in tables): a run ID hashes the resolved plan,
    # whose last bits depend on the CPU's BLAS kernels (docs/archive-format.md, run IDs), so the
    # IDs README.md shows are those of the machine it was written on
    (re.compile(r"\b[0-9a-f]{10}(?:[0-9a-f]{10})?\b"), "<RUN-ID>"),
    # a float printed in full (--json): its last digits depend on the CPU as the IDs do; kept
    # to 12 significant digits (platforms differ by at most 1e-9 relative, measured:
    # tools/kernel_fingerprint.py)
    (re.compile(r"-?\d+\.\d{13,}"), lambda m: f"{float(m.group()):.12g}"),
)


@dataclass(frozen=True)
class Block:
    index: int
    line: int  # 1-based line of the opening fence
    lang: str
    script: str  # what bash runs
    first: str  # the first command, for the test ID
    skip: str | None  # the reason, when marked
    #: a console block's commands and what README.md shows they print
    shown: tuple[Shown, ...] = ()


@dataclass(frozen=True)
class Shown:
    """One ``$`` command of a console block and the output lines shown under it."""

    line: int  # 1-based README line of the ``$``
    command: str
    output: tuple[tuple[int, str], ...]  # (README line, text)


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


def _shown(body: list[str], first_line: int) -> tuple[Shown, ...]:
    """A console block's ``$`` commands (with their ``\\`` continuations) and the lines shown
    under each; ``first_line`` is the README line of the body's first line."""
    out: list[Shown] = []
    command: list[str] = []
    output: list[tuple[int, str]] = []
    at = 0
    continued = False
    for k, line in enumerate(body):
        if line.startswith("$ ") or continued:
            if line.startswith("$ "):
                if command:
                    out.append(Shown(at, "\n".join(command), tuple(output)))
                command, output, at = [line[2:]], [], first_line + k
            else:
                command.append(line)
            continued = line.rstrip().endswith("\\")
        elif command:
            output.append((first_line + k, line))
    if command:
        out.append(Shown(at, "\n".join(command), tuple(output)))
    return tuple(out)


def _marked(shown: tuple[Shown, ...]) -> str:
    """The console block's script with a marker line before each command (stdout and stderr)."""
    lines = []
    for k, cmd in enumerate(shown):
        lines.append(f"printf '%s\\n' '{MARK}{k}' && printf '%s\\n' '{MARK}{k}' >&2")
        lines.append(cmd.command)
    return "\n".join(lines) + "\n"


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
        shown = _shown(body, start + 2) if lang == "console" else ()
        blocks.append(
            Block(
                index=len(blocks),
                line=start + 1,
                lang=lang,
                script=script,
                first=first.split("#")[0].strip(),
                skip=marker.group("reason") if marker else None,
                shown=shown,
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
        script = _marked(block.shown) if block.shown else block.script
        proc = subprocess.run(
            ["bash", "-e", "-o", "pipefail", "-c", script],
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
    proc = tour.run(block)
    problems = _compare(block, proc, tour.env["BOWLREC_ARCHIVE"])
    assert not problems, "\n\n".join(problems)


# --- what the console blocks show ---------------------------------------------------------------


def normalized(line: str, archive: str) -> str:
    """``line`` with the archive's path (``archive``, or README.md's :data:`README_ARCHIVE`) and
    :data:`VARIES` replaced, the padding of table cells collapsed (runs of spaces and of
    horizontal box lines) and the ends stripped: the text that must be the same in README.md and
    in a run."""
    line = line.replace(archive, "<ARCHIVE>").replace(README_ARCHIVE, "<ARCHIVE>")
    for pattern, replacement in VARIES:
        line = pattern.sub(replacement, line)
    line = re.sub(r"([─━])\1+", r"\1", line)
    return re.sub(r"\s+", " ", line).strip()


def _line_pattern(shown: str) -> re.Pattern[str]:
    """A shown line as a pattern: ``...`` inside it stands for omitted text."""
    return re.compile(".*".join(re.escape(part) for part in shown.split("...")))


def _in_order(
    output: tuple[tuple[int, str], ...], printed: list[str], archive: str
) -> tuple[int, str] | None:
    """The first shown line (README line, text) that ``printed`` (normalized) does not show in
    order after the ones before it, or None; ``...`` lines are skipped."""
    pos = 0
    for n, text in output:
        if not text.strip() or text.strip() == "...":
            continue
        pattern = _line_pattern(normalized(text, archive))
        at = next((i for i in range(pos, len(printed)) if pattern.fullmatch(printed[i])), None)
        if at is None:
            return n, text
        pos = at + 1
    return None


def _split(stream: str, n: int) -> list[list[str]]:
    """A console block's stdout or stderr split at the markers into the n commands' lines."""
    parts: list[list[str]] = [[] for _ in range(n)]
    k = -1
    for line in stream.splitlines():
        if line.startswith(MARK):
            k = int(line[len(MARK) :])
        elif k >= 0:
            parts[k].append(line)
    return parts


def _compare(block: Block, proc: subprocess.CompletedProcess[str], archive: str) -> list[str]:
    """What the console block's commands print against what README.md shows (module doc):
    one message per command that differs, with the README line and the real output."""
    problems = []
    outs = _split(proc.stdout, len(block.shown))
    errs = _split(proc.stderr, len(block.shown))
    for k, shown in enumerate(block.shown):
        raw = outs[k] + errs[k]
        printed = [x for x in (normalized(line, archive) for line in raw) if x]
        bad = _in_order(shown.output, printed, archive)
        if bad is not None:
            problems.append(
                f"README.md line {bad[0]}: {bad[1].strip()!r} is not what `$ {shown.command}` "
                f"(line {shown.line}) prints (in order after the lines shown before it):\n"
                + "\n".join(raw[-60:])
            )
    return problems


def test_shown_output_is_compared_exactly_but_for_what_varies() -> None:
    """The comparison of the console blocks: the archive's path, timestamps, elapsed times,
    throughputs, run IDs and the last digits of a float printed in full may differ and table
    padding follows the cells; anything else may not."""
    here = "/tmp/pytest-of-x/readme0/archive"
    shown = (
        (1, f"│ run │ 7834deb0f6f26fc5964b stored in {README_ARCHIVE} │"),
        (2, "..."),
        (3, "│ 48c8b08cd1 │ 2026-11-27 17:06:29 │ pins    │    16.212 │"),
        (4, '{"outcome": "pins", "slide_m": 16.212245620581463, ...}'),
        (5, "20 runs: 20 new (20 simulated in 5.3 s, 3,774 runs/s)"),
    )
    printed = [
        f"│ run          │ 81c7c797d4d7a4cd9916 stored in {here}   │",
        "│ events │ zone@12.19m │",
        "┃ 48c8b08cd1 ┃",
        "│ bf334f2901 │ 2026-11-28 07:06:07 │ pins │ 16.212 │",
        '{"outcome": "pins", "slide_m": 16.212245620581466, "hook_m": 0.596}',
        "20 runs: 20 new (20 simulated in 12 s, 1,002.5 runs/s)",
    ]
    ok = [normalized(x, here) for x in printed]
    assert _in_order(shown, ok, here) is None
    for k, wrong in (
        (0, f"│ run │ stored in {here} │"),  # no run ID
        (3, "│ bf334f2901 │ 2026-11-28 07:06:07 │ pins │ 16.213 │"),  # another number
        (4, '{"outcome": "pins", "slide_m": 16.212245621581466, "hook_m": 0.596}'),
        (5, "20 runs: 19 new (20 simulated in 12 s, 1,002.5 runs/s)"),
    ):
        bad = [*ok[:k], normalized(wrong, here), *ok[k + 1 :]]
        assert _in_order(shown, bad, here) is not None, wrong
    assert _in_order(shown, ok[::-1], here) is not None  # out of order
    assert _in_order(shown, ok[:-1], here) == shown[-1]  # missing


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
