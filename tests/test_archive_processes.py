"""The archive with several processes (the ``process`` tier: children started, not killed):
concurrent creation, eight processes adding balls, a reader without write access (as user
nobody), a full disk (a small tmpfs, the command line in a child), a damaged index read by a
new process, and a reader listing while the index is rebuilt again and again.

Child processes: tests/archive_fault_child.py.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from helpers.archive_contract import (
    Template,
    assert_same_trajectory,
    collect,
    copy_of,
    damage_index,
    indexed_archive,
    library,
    listed,
    make_template,
    recorded_scene,
    seal,
    snapshot,
    spawn,
    temporaries,
    wait_ready,
)

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, ArchiveWriteError

pytestmark = pytest.mark.process

NOBODY = 65534


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Template:
    return make_template(tmp_path_factory.mktemp("template"))


def test_concurrent_creation_refuses_none(tmp_path: Path) -> None:
    """3 processes open ``Archive(new_dir)`` at (nearly) the same moment, 60 times: all
    succeed and each directory is one valid, empty archive."""
    children = [spawn("create", stdin=subprocess.PIPE) for _ in range(3)]
    try:
        for c in children:
            wait_ready(c)
        dirs = [tmp_path / f"new{i}" / "archive" for i in range(60)]
        rng = random.Random(3)
        for d in dirs:
            for c in children:  # within 0-40 ms (varied: many interleavings), before any answer
                assert c.stdin is not None
                time.sleep(rng.uniform(0.0, 0.02))
                c.stdin.write(f"{d}\n")
                c.stdin.flush()
            answers = []
            for c in children:
                assert c.stdout is not None
                answers.append(c.stdout.readline().strip())
            assert answers == ["ok"] * 3, (d, answers)
    finally:
        for c in children:
            if c.stdin is not None:
                c.stdin.close()
            c.wait(timeout=30)
    for d in dirs:
        archive = Archive(d, create=False)
        assert archive.list_runs() == []
        assert archive.balls.list() == []
        names = {p.name for p in d.iterdir()}
        assert names <= {
            "archive.json",
            "index.sqlite",
            "segments",
            "balls",
            "tombstones",
            ".writer.lock",
        }, names


def test_eight_processes_adding_balls(tmp_path: Path) -> None:
    """8 processes add 50 balls each at once: 40 names of their own, 5 shared names with a
    spec of their own (8 versions each), 5 shared names with one spec (1 version)."""
    root = tmp_path / "a"
    Archive(root)
    children = [spawn("balls", str(root), str(i), stdin=subprocess.PIPE) for i in range(8)]
    for c in children:
        wait_ready(c)
    for c in children:
        assert c.stdin is not None
        c.stdin.write("go\n")
        c.stdin.flush()
    results: list[dict[str, Any]] = []
    for i, c in enumerate(children):
        out, err = collect(c)
        assert c.returncode == 0, f"process {i} failed:\n{err}"
        lines = [json.loads(line) for line in out.splitlines() if line.strip()]
        assert len(lines) == 50, f"process {i}: {len(lines)} adds"
        results += [{**r, "proc": i} for r in lines]

    for r in results:  # each add returned the entry of the spec it was given
        assert r["sha"] == r["spec_sha"], r
    own = [r for r in results if r["name"].startswith("p")]
    assert len(own) == 320 and all(r["version"] == 1 and r["added"] for r in own)
    for k in range(5):
        shared = [r for r in results if r["name"] == f"shared-{k}"]
        assert all(r["added"] for r in shared)
        assert sorted(r["version"] for r in shared) == list(range(1, 9)), shared
        same = [r for r in results if r["name"] == f"same-{k}"]
        assert {r["version"] for r in same} == {1} and len({r["sha"] for r in same}) == 1
        assert sum(r["added"] for r in same) == 1, same

    archive = Archive(root)
    library = {(e.name, e.version): e.sha for e in archive.balls.list(all_versions=True)}
    assert library == {(r["name"], r["version"]): r["sha"] for r in results}
    on_disk = {(p.parent.name, int(p.stem)) for p in (root / "balls").glob("*/*.json")}
    assert on_disk == set(library)
    archive.reindex()  # the index rebuilt from the ball files says the same
    assert {(e.name, e.version): e.sha for e in archive.balls.list(all_versions=True)} == library


def _reader_mode() -> str:
    """How to run a reader as user ``nobody``: "direct" (subprocess user=), "drop" (the child
    starts as root and drops to nobody after importing what it needs), or a skip."""
    if os.geteuid() != 0:
        pytest.skip("needs root to run a reader as another user (nobody)")
    try:
        probe = subprocess.run(
            [sys.executable, "-c", "import bowlrec.archive"],
            user=NOBODY,
            group=NOBODY,
            extra_groups=[],
            cwd="/",
            capture_output=True,
            timeout=60,
        )
    except (OSError, subprocess.SubprocessError):
        return "drop"
    return "direct" if probe.returncode == 0 else "drop"


@dataclass(frozen=True)
class ReadOnlyArchive:
    """An archive every user may read (not write) and its ball library as (name, version, sha)."""

    root: Path
    balls: list[list[Any]]


@pytest.fixture
def readonly_archive(template: Template, tmp_path: Path) -> Iterator[ReadOnlyArchive]:
    """Runs 1-3 in two segments and three ball versions, outside pytest's root-only directories."""
    top = Path(tempfile.mkdtemp(prefix="bowlrec-ro-", dir="/tmp"))
    try:
        root = top / "a"
        archive = Archive(root)
        seal(archive, [copy_of(template.run, 1), copy_of(template.run, 2)])
        seal(archive, [copy_of(template.run, 3)])
        ball = template.run.scene.ball
        archive.balls.add("house", ball)
        archive.balls.add("house", ball.model_copy(update={"mass_kg": 7.0}))
        archive.balls.add("spare", ball.model_copy(update={"mass_kg": 6.0}))
        balls = [[e.name, e.version, e.sha] for e in archive.balls.list(all_versions=True)]
        assert [b[:2] for b in balls] == [["house", 1], ["house", 2], ["spare", 1]]
        (root / ".writer.lock").unlink()
        for p in [top, *top.rglob("*")]:
            p.chmod(0o755 if p.is_dir() else 0o644)
        yield ReadOnlyArchive(root, balls)
    finally:
        shutil.rmtree(top, ignore_errors=True)


def _read_as_nobody(root: Path, tmp_path: Path) -> dict[str, Any]:
    mode = _reader_mode()
    if mode == "direct":
        child = spawn("reader", str(root), user=NOBODY, group=NOBODY, extra_groups=[], cwd="/")
    else:
        warm = tmp_path / f"warm-{time.monotonic_ns()}"
        shutil.copytree(root, warm)
        child = spawn("reader", str(root), str(warm), str(NOBODY), cwd="/")
    out, err = child.communicate(timeout=120)
    if mode == "drop" and "Operation not permitted" in err:
        pytest.skip(f"cannot drop to user nobody here: {err.strip().splitlines()[-1]}")
    assert child.returncode == 0, f"reader ({mode}) failed:\n{err}"
    doc: dict[str, Any] = json.loads(out)
    assert doc["euid"] == NOBODY
    assert doc["writable"] is False, "the reader could write the archive: the test proves nothing"
    return doc


def _check_read(doc: dict[str, Any], ro: ReadOnlyArchive, template: Template) -> None:
    arrays = {k: v.tobytes().hex() for k, v in template.run.trajectory.arrays().items()}
    ids = [f"{i:020x}" for i in (1, 2, 3)]
    assert sorted(doc["runs"]) == ids
    assert doc["loaded"] == dict.fromkeys(ids, arrays)  # every run loaded, bit-identical
    assert doc["balls"] == ro.balls


def test_reader_without_write_access_creates_nothing(
    readonly_archive: ReadOnlyArchive, template: Template, tmp_path: Path
) -> None:
    """User nobody lists runs, loads them and lists the balls; no file is created or touched
    (no .writer.lock, no journal)."""
    root = readonly_archive.root
    before = snapshot(root)
    doc = _read_as_nobody(root, tmp_path)
    assert snapshot(root) == before
    _check_read(doc, readonly_archive, template)


@pytest.mark.parametrize("damage", ["missing", "garbled"])
def test_reader_without_write_access_lists_without_an_index(
    readonly_archive: ReadOnlyArchive, template: Template, tmp_path: Path, damage: str
) -> None:
    """index.sqlite missing or garbled and the reader may not write: it still lists and loads
    (an index built in memory) and writes nothing."""
    root = readonly_archive.root
    index = root / "index.sqlite"
    if damage == "missing":
        index.unlink()
    else:
        index.write_bytes(random.Random(4).randbytes(index.stat().st_size))
    before = snapshot(root)
    doc = _read_as_nobody(root, tmp_path)
    assert snapshot(root) == before
    if damage == "missing":
        assert not index.exists()
    _check_read(doc, readonly_archive, template)


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 3 MB tmpfs (skips when mounting is not allowed)."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    try:
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mnt)],
            capture_output=True,
            text=True,
            timeout=30,
        )
    except (OSError, subprocess.SubprocessError) as err:
        pytest.skip(f"cannot mount a small tmpfs for the full-disk test: {err}")
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs for the full-disk test: {done.stderr.strip()}")
    try:
        yield mnt
    finally:
        if subprocess.run(["umount", str(mnt)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def _fill(directory: Path) -> Path:
    """Write a file until the file system is full; its path."""
    filler = directory / "filler"
    with open(filler, "wb", buffering=0) as f:
        for block in (1 << 16, 1 << 12, 1 << 9, 1):
            with contextlib.suppress(OSError):
                while True:
                    f.write(b"\0" * block)
    assert shutil.disk_usage(directory).free < 4096
    return filler


def _bowlrec_cli() -> list[str]:
    script = Path(sys.executable).parent / "bowlrec"
    return [str(script)] if script.exists() else [sys.executable, "-m", "bowlrec.cli"]


def test_full_disk(small_disk: Path, template: Template, tmp_path: Path) -> None:
    """On a full file system adding a run raises ArchiveWriteError with one clear message (the
    CLI prints one ``error:`` line, no traceback), earlier runs still load, repair leaves no
    temporaries, and once space is freed adding works again."""
    root = small_disk / "a"
    archive = Archive(root)
    for i in range(3):
        assert archive.add(copy_of(template.run, i), wall_time_s=0.0).added
    filler = _fill(small_disk)

    with pytest.raises(ArchiveWriteError) as info:
        archive.add(copy_of(template.run, 10), wall_time_s=0.0)
    message = str(info.value)
    assert "\n" not in message.strip(), message
    assert re.search(r"no space|disk full|ENOSPC", message, re.IGNORECASE), message
    with pytest.raises(ArchiveWriteError):
        simulate_into(archive, recorded_scene(7.3))

    scene_file = tmp_path / "scene.json"
    scene_file.write_text(recorded_scene(7.1).model_dump_json())
    cli = subprocess.run(
        [*_bowlrec_cli(), "simulate", str(scene_file), "-a", str(root), "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert cli.returncode != 0
    lines = cli.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), cli.stderr
    assert re.search(r"no space|disk full|ENOSPC", lines[0], re.IGNORECASE), lines[0]

    fresh = Archive(root)
    assert sorted(listed(fresh)) == [f"{i:020x}" for i in range(3)]
    for i in range(3):
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.run.trajectory)
    report = fresh.repair(min_age_s=0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == []
    assert temporaries(root) == []

    filler.unlink()
    assert fresh.add(copy_of(template.run, 10), wall_time_s=0.0).added
    assert_same_trajectory(fresh.load(f"{10:020x}").trajectory, template.run.trajectory)
    assert simulate_into(fresh, recorded_scene(7.1)).added
    assert len(fresh.list_runs()) == 5


def test_full_disk_stops_a_batch_with_one_line_and_its_table(
    small_disk: Path, template: Template, tmp_path: Path
) -> None:
    """A batch whose archive fills up stops with exit 1 and one ``error:`` line, writes its
    summary table (up to the last run reached; the runs it could not archive are failed rows
    that say why), keeps every run archived before, and a rerun after space is freed archives
    the rest."""
    import csv

    root = small_disk / "a"
    archive = Archive(root)
    for i in range(3):
        archive.add(copy_of(template.run, i), wall_time_s=0.0)
    filler = _fill(small_disk)
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "format": "bowlrec-job",
                "name": "fills",
                "base": {"options": {"record": "summary"}},
                "sweep": {
                    "kind": "grid",
                    "axes": {"delivery.speed_mps": {"start": 6.0, "stop": 9.0, "num": 40}},
                },
            }
        )
    )
    cmd = [*_bowlrec_cli(), "batch", str(job), "-a", str(root), "--workers", "0", "--quiet"]
    out = subprocess.run([*cmd, "--out", str(tmp_path / "t1")], capture_output=True, text=True)
    assert out.returncode == 1, out.stderr
    lines = out.stderr.strip().splitlines()  # --quiet: the summary line and the error
    assert len(lines) == 2 and lines[0].startswith("40 runs: "), out.stderr
    assert lines[1].startswith("error:") and re.search(r"no space", lines[1], re.IGNORECASE)
    with open(tmp_path / "t1.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert 0 < len(rows) <= 40
    assert [int(r["index"]) for r in rows] == list(range(len(rows)))
    assert all(r["status"] == "failed" and "not archived" in r["error"] for r in rows)
    fresh = Archive(root)
    assert sorted(listed(fresh)) == [f"{i:020x}" for i in range(3)]

    filler.unlink()
    again = subprocess.run([*cmd, "--out", str(tmp_path / "t2")], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    with open(tmp_path / "t2.csv", newline="") as fh:
        assert {r["status"] for r in csv.DictReader(fh)} == {"ok"}
    assert len(Archive(root).list_runs()) == 43


@pytest.mark.parametrize("damage", ["garbled", "deleted"])
def test_damaged_index_read_by_a_new_process(
    tmp_path: Path, template: Template, damage: str
) -> None:
    """A garbled or deleted index.sqlite: a new process lists the runs and the ball library as
    before (from the data files), the removed run stays removed, and the file is left as it
    was (reads never write)."""
    root = tmp_path / "a"
    archive = indexed_archive(root, template.run)
    runs, balls = sorted(listed(archive)), library(archive)
    assert len(runs) == 8 and len(balls) == 3
    index = root / "index.sqlite"
    damage_index(index, damage)
    before = index.read_bytes() if index.exists() else None
    child = spawn("reader", str(root))
    out, err = child.communicate(timeout=120)
    assert child.returncode == 0, err
    doc = json.loads(out)
    assert sorted(doc["runs"]) == runs
    assert [tuple(b) for b in doc["balls"]] == [lib[:3] for lib in balls]
    arrays = {k: v.tobytes().hex() for k, v in template.run.trajectory.arrays().items()}
    assert all(a == arrays for a in doc["loaded"].values())
    assert (index.read_bytes() if index.exists() else None) == before
    assert library(Archive(root)) == balls


def test_reindex_while_another_process_reads(tmp_path: Path, template: Template) -> None:
    """A reader listing runs in a loop while the index is rebuilt 12 times (each time with a
    sealed segment more): every count it sees is a whole index, old or new, never partial."""
    root = tmp_path / "a"
    archive = Archive(root)
    seal(archive, [copy_of(template.run, i) for i in range(30)])
    counts = [30]
    stop = tmp_path / "stop"
    child = spawn("count", str(root), str(stop))
    try:
        wait_ready(child)
        next_index = 1000
        for r in range(12):
            n = 5 + 3 * r
            seal(archive, [copy_of(template.run, next_index + k) for k in range(n)], register=False)
            next_index += n
            counts.append(counts[-1] + n)
            time.sleep(0.05)
            assert archive.reindex() == counts[-1]
            time.sleep(0.05)
    finally:
        stop.touch()
    out, err = collect(child)
    assert child.returncode == 0, err
    doc = json.loads(out)
    assert doc["n_errors"] == 0, doc["errors"]
    seen: list[int] = doc["counts"]
    assert len(seen) >= 50, "the reader hardly ran"
    odd = sorted(set(seen) - set(counts))
    assert not odd, f"the reader saw partial indexes: counts {odd} (valid: {counts})"
    assert seen == sorted(seen), "the reader saw an older index after a newer one"
    assert len(set(seen)) >= 3, f"the reader saw too few rebuilds to test anything: {set(seen)}"
