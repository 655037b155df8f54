"""Fault behaviour of the archive (format 2.0), checked for real: writers killed with SIGKILL,
concurrent writers and creators, a reader without write access, a full disk, damaged segments
and a damaged or missing index.

Child processes: tests/archive_fault_child.py. The heavy variants are marked ``slow`` and, as
in test_stress_properties.py, run only when selected with ``-m slow``.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

import bowlrec
from bowlrec.api import simulate_into
from bowlrec.archive import (
    Archive,
    ArchiveWriteError,
    RunDamagedError,
    RunNotFoundError,
    SegmentFile,
    run_id,
)
from bowlrec.core.trajectory import Trajectory
from bowlrec.paper import paper_scene
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import read_run_file, write_run_file
from bowlrec.spec import Scene

HERE = Path(__file__).parent
CHILD = HERE / "archive_fault_child.py"
NOBODY = 65534


# -- helpers -------------------------------------------------------------------------------------


def require_slow_selected(request: pytest.FixtureRequest) -> None:
    """Heavy variants run only when asked for by marker (``-m slow``); a plain run skips them."""
    if "slow" not in (request.config.getoption("markexpr", "") or ""):
        pytest.skip("heavy fault variant: select it with -m slow")


def _scene(speed_mps: float | None = None, *, terms: bool = False) -> Scene:
    """The paper's scene 16, recorded every 50 ms (57 samples: small segments, fast loads)."""
    base = paper_scene(16).model_dump(mode="json")
    base["options"] = {"record": "rate", "record_dt_s": 0.05, "record_terms": terms}
    if speed_mps is not None:
        base["delivery"]["speed_mps"] = speed_mps
    return Scene.model_validate(base)


@dataclass(frozen=True)
class Template:
    """A run file the writer children copy, and the run as read back from it."""

    path: Path
    run: RunData


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Template:
    scene = _scene()
    run = RunData(scene, scene.resolve(), bowlrec.simulate(scene))
    path = write_run_file(tmp_path_factory.mktemp("template") / "template.h5", run, {})
    stored = read_run_file(path)
    return Template(path, RunData(stored.scene, stored.scene.resolve(), stored.trajectory))


def _copy(template: Template, i: int) -> RunData:
    """Copy ``i`` of the template run (run ID ``f"{i:020x}"``, as the writer children use)."""
    return RunData(template.run.scene, template.run.plan, template.run.trajectory, f"{i:020x}")


def assert_same_trajectory(got: Trajectory, want: Trajectory, what: str = "") -> None:
    """Bit-identical arrays (dtype, shape, bytes), events and summary."""
    a, b = got.arrays(), want.arrays()
    assert a.keys() == b.keys(), what
    for key, arr in a.items():
        assert arr.dtype == b[key].dtype, (what, key)
        assert arr.shape == b[key].shape, (what, key)
        assert arr.tobytes() == b[key].tobytes(), (what, key)
    assert got.events == want.events, what
    assert got.summary == want.summary, what


def _seal(archive: Archive, runs: Sequence[RunData], *, register: bool = True) -> Path:
    builder = archive.builder()
    for run in runs:
        builder.append(archive.record(run, wall_time_s=0.0))
    info = archive.seal(builder)
    if register:
        archive.register([info])
    return info.path


def _listed(archive: Archive) -> list[str]:
    return [r["run_id"] for r in archive.list_runs()]


def _ids_in_segment_files(root: Path) -> list[str]:
    """Run IDs of every sealed segment file (with repeats when several files hold a run)."""
    ids: list[str] = []
    for path in sorted((root / "segments").glob("*.h5")):
        with SegmentFile(path) as seg:
            ids += seg.run_ids()
    return ids


def _parts(root: Path) -> list[Path]:
    return sorted(root.rglob("*.part"))


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Every file and directory under ``root``: (size, mtime ns)."""
    return {
        str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in sorted(root.rglob("*"))
    }


def _spawn(*args: str, **kwargs: Any) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, str(CHILD), *args],
        stdin=kwargs.pop("stdin", subprocess.DEVNULL),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def _wait_ready(child: subprocess.Popen[str]) -> None:
    assert child.stdout is not None
    line = child.stdout.readline().strip()
    if line != "ready":
        child.kill()
        _, err = _collect(child)
        raise AssertionError(f"child did not start: {line!r}\n{err}")


def _collect(child: subprocess.Popen[str]) -> tuple[str, str]:
    """The rest of a child's stdout and its stderr, once it exits. (Not communicate(): after a
    readline() it would miss what the text wrapper had already buffered.)"""
    assert child.stdout is not None and child.stderr is not None
    out = child.stdout.read()
    err = child.stderr.read()
    child.wait(timeout=60)
    return out, err


# -- 1. SIGKILL campaign -------------------------------------------------------------------------

#: phases of a writer child (the last marker it printed): seal and register are mid-write
MID_WRITE = ("seal", "register")


@dataclass
class WriterOutput:
    """What a killed writer child printed."""

    reported: list[str] = field(default_factory=list)
    #: the run IDs of the segment it was working on when killed (empty between segments)
    in_flight: list[str] = field(default_factory=list)
    #: the last phase marker: ready, begin, seal, register, done or finished
    phase: str = "start"
    #: the highest run index it planned (-1: none)
    last_index: int = -1


def _parse_writer(out: str) -> WriterOutput:
    w = WriterOutput()
    for line in out.splitlines():
        word, _, rest = line.strip().partition(" ")
        if word == "run":
            w.reported.append(rest)
        elif word == "begin":
            first, n = rest.split()
            start = int(first, 16)
            w.in_flight = [f"{k:020x}" for k in range(start, start + int(n))]
            w.last_index = start + int(n) - 1
            w.phase = "begin"
        elif word in ("ready", "seal", "register", "done", "finished"):
            w.phase = word
            if word in ("done", "finished"):
                w.in_flight = []
    return w


def _writer(root: Path, template: Template, start: int, stop: int, seed: int) -> Any:
    return _spawn("writer", str(root), str(template.path), str(start), str(stop), str(seed))


def _kill(child: subprocess.Popen[str]) -> WriterOutput:
    with contextlib.suppress(ProcessLookupError):
        os.kill(child.pid, signal.SIGKILL)
    out, err = _collect(child)
    # killed (-9), or finished its range first (0); anything else is a writer failure
    assert child.returncode in (-signal.SIGKILL, 0), err
    return _parse_writer(out)


def _check_after_kill(
    root: Path,
    template: Template,
    archived: set[str],
    outputs: Sequence[WriterOutput],
    rng: random.Random,
    loads: int | None,
    *,
    distinct: bool,
) -> set[str]:
    """Before any repair: every reported run is listed once and loads bit-identically (all new
    ones, or ``loads`` of them, and 10 older ones); at most the killed writers' in-flight
    segments appear beyond them. Then repair: no damage, no temporaries, index rows == runs in
    the segment files (``distinct``: no run is in two files). The run IDs now archived."""
    archive = Archive(root)
    listed = _listed(archive)
    assert len(listed) == len(set(listed)), "a run is listed twice"
    reported = {rid for w in outputs for rid in w.reported}
    missing = (reported | archived) - set(listed)
    assert not missing, f"{len(missing)} reported run(s) not listed, e.g. {sorted(missing)[:3]}"
    allowed = reported | archived | {rid for w in outputs for rid in w.in_flight}
    strays = set(listed) - allowed
    assert not strays, f"runs nobody wrote: {sorted(strays)[:3]}"
    new = sorted(reported - archived)
    to_load = new if loads is None else rng.sample(new, min(len(new), loads))
    to_load += rng.sample(sorted(archived), min(len(archived), 10))
    for rid in to_load:
        assert_same_trajectory(archive.load(rid).trajectory, template.run.trajectory, rid)

    report = archive.repair(min_age_s=0)
    assert _parts(root) == []
    assert report["damaged_runs"] == [], report
    assert report["quarantined_segments"] == [], report
    assert archive.damaged() == []
    in_files = _ids_in_segment_files(root)
    after = _listed(archive)
    assert len(after) == len(set(after)) == len(archive)
    assert set(after) == set(in_files), "index rows != runs in the segment files"
    if distinct:
        assert len(after) == len(in_files), "index rows != runs in the segment files"
    assert set(after) <= allowed
    return set(after)


def _kill_campaign(
    root: Path,
    template: Template,
    *,
    kills: int,
    concurrent_rounds: int,
    loads: int | None,
    seed: int,
) -> None:
    rng = random.Random(seed)
    Archive(root)
    archived: set[str] = set()
    next_index = 0
    phases: list[str] = []
    parts_left = 0
    for k in range(kills):
        child = _writer(root, template, next_index, -1, seed * 1000 + k)
        _wait_ready(child)
        time.sleep(rng.uniform(0.02, 0.25))
        w = _kill(child)
        phases.append(w.phase)
        parts_left += bool(_parts(root))
        archived = _check_after_kill(root, template, archived, [w], rng, loads, distinct=True)
        next_index = max(next_index, w.last_index + 1)
    mid = sum(p in MID_WRITE for p in phases) / len(phases)
    print(f"{kills} kills: phases {phases}; {parts_left} left a .part file")
    assert mid >= 0.6, f"only {mid:.0%} of the kills landed mid-write: {phases}"
    assert len(archived) > 0

    # 2-3 writers at once, two of them writing the same run IDs, killed at random moments
    span = 150
    for r in range(concurrent_rounds):
        base = next_index
        ranges = [(base, base + span), (base, base + span), (base + span, base + 2 * span)]
        n_writers = 3 if r % 2 == 0 else 2
        children = [
            _writer(root, template, a, b, seed * 1000 + 500 + 10 * r + i)
            for i, (a, b) in enumerate(ranges[:n_writers])
        ]
        for c in children:
            _wait_ready(c)
        start = time.monotonic()
        outputs = []
        for c, at in sorted(
            ((c, rng.uniform(0.1, 1.2)) for c in children), key=lambda item: item[1]
        ):
            time.sleep(max(0.0, at - (time.monotonic() - start)))
            outputs.append(_kill(c))
        archived = _check_after_kill(root, template, archived, outputs, rng, 60, distinct=False)
        next_index = base + 2 * span


def test_sigkill_campaign_loses_nothing_reported(tmp_path: Path, template: Template) -> None:
    """~8 writers killed at random moments (most mid-seal or mid-register), then 2 rounds of
    concurrent writers (two on the same run IDs) killed at random moments. After each: no run
    reported done is lost or damaged, before any repair; repair finds no damage and leaves the
    index equal to the segment files."""
    _kill_campaign(tmp_path / "a", template, kills=8, concurrent_rounds=2, loads=40, seed=1)


@pytest.mark.slow
def test_sigkill_campaign_heavy(
    tmp_path: Path, template: Template, request: pytest.FixtureRequest
) -> None:
    """Heavy variant: 20 kills with every reported run loaded, 4 concurrent rounds."""
    require_slow_selected(request)
    _kill_campaign(tmp_path / "a", template, kills=20, concurrent_rounds=4, loads=None, seed=2)


#: the first bytes of a rollback journal that SQLite would play back (a "hot" journal)
JOURNAL_MAGIC = bytes.fromhex("d9d505f920a163d7")


def test_writer_killed_mid_commit_readers_still_list(tmp_path: Path, template: Template) -> None:
    """A writer killed inside its index transaction after SQLite spilled pages to index.sqlite
    (a hot rollback journal left, as by a kill during COMMIT): with no repair, this process
    (which had the index open) and a new process still list the runs registered before (plus
    the killed writer's sealed segment, if a recovery registered it); then repair leaves the
    index equal to the segment files."""
    root = tmp_path / "a"
    archive = Archive(root)
    _seal(archive, [_copy(template, i) for i in range(400)])  # pages the COMMIT rewrites
    before = sorted(_listed(archive))
    child = _spawn("die-in-commit", str(root), str(template.path), "1000", "400")
    out, err = child.communicate(timeout=120)
    assert child.returncode == -signal.SIGKILL and out.strip() == "killing", err
    journal = root / "index.sqlite-journal"
    assert journal.exists() and journal.read_bytes()[:8] == JOURNAL_MAGIC, "no hot journal"

    # a reader may see the killed writer's sealed segment registered by a recovery, or not
    killed = sorted(f"{i:020x}" for i in range(1000, 1400))
    valid = (before, sorted(before + killed))
    assert sorted(_listed(archive)) in valid  # the connection this process had open
    assert sorted(_listed(Archive(root))) in valid
    for rid in before[:3]:
        assert_same_trajectory(archive.load(rid).trajectory, template.run.trajectory)
    reader = _spawn("reader", str(root))
    out, err = reader.communicate(timeout=120)
    assert reader.returncode == 0, err
    assert sorted(json.loads(out)["runs"]) in valid

    report = Archive(root).repair(min_age_s=0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == [], report
    after = _listed(Archive(root))
    assert sorted(after) == sorted(set(_ids_in_segment_files(root)))
    assert len(after) == 800 and not journal.exists()


# -- 2. concurrent creation ----------------------------------------------------------------------


def test_concurrent_creation_refuses_none(tmp_path: Path) -> None:
    """3 processes open ``Archive(new_dir)`` at (nearly) the same moment, 60 times: all
    succeed and each directory is one valid, empty archive."""
    children = [_spawn("create", stdin=subprocess.PIPE) for _ in range(3)]
    try:
        for c in children:
            _wait_ready(c)
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


# -- 3. concurrent ball library ------------------------------------------------------------------


def test_eight_processes_adding_balls(tmp_path: Path) -> None:
    """8 processes add 50 balls each at once: 40 names of their own, 5 shared names with a
    spec of their own (8 versions each), 5 shared names with one spec (1 version)."""
    root = tmp_path / "a"
    Archive(root)
    children = [_spawn("balls", str(root), str(i), stdin=subprocess.PIPE) for i in range(8)]
    for c in children:
        _wait_ready(c)
    for c in children:
        assert c.stdin is not None
        c.stdin.write("go\n")
        c.stdin.flush()
    results: list[dict[str, Any]] = []
    for i, c in enumerate(children):
        out, err = _collect(c)
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


# -- 4. reading without write access -------------------------------------------------------------


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
        _seal(archive, [_copy(template, 1), _copy(template, 2)])
        _seal(archive, [_copy(template, 3)])
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
        child = _spawn("reader", str(root), user=NOBODY, group=NOBODY, extra_groups=[], cwd="/")
    else:
        warm = tmp_path / f"warm-{time.monotonic_ns()}"
        shutil.copytree(root, warm)
        child = _spawn("reader", str(root), str(warm), str(NOBODY), cwd="/")
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
    before = _snapshot(root)
    doc = _read_as_nobody(root, tmp_path)
    assert _snapshot(root) == before
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
    before = _snapshot(root)
    doc = _read_as_nobody(root, tmp_path)
    assert _snapshot(root) == before
    if damage == "missing":
        assert not index.exists()
    _check_read(doc, readonly_archive, template)


# -- 5. full disk --------------------------------------------------------------------------------


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
        assert archive.add(_copy(template, i), wall_time_s=0.0).added
    filler = _fill(small_disk)

    with pytest.raises(ArchiveWriteError) as info:
        archive.add(_copy(template, 10), wall_time_s=0.0)
    message = str(info.value)
    assert "\n" not in message.strip(), message
    assert re.search(r"no space|disk full|ENOSPC", message, re.IGNORECASE), message
    with pytest.raises(ArchiveWriteError):
        simulate_into(archive, _scene(7.3))

    scene_file = tmp_path / "scene.json"
    scene_file.write_text(_scene(7.1).model_dump_json())
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
    assert sorted(_listed(fresh)) == [f"{i:020x}" for i in range(3)]
    for i in range(3):
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.run.trajectory)
    report = fresh.repair(min_age_s=0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == []
    assert _parts(root) == []

    filler.unlink()
    assert fresh.add(_copy(template, 10), wall_time_s=0.0).added
    assert_same_trajectory(fresh.load(f"{10:020x}").trajectory, template.run.trajectory)
    assert simulate_into(fresh, _scene(7.1)).added
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
        archive.add(_copy(template, i), wall_time_s=0.0)
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
    assert sorted(_listed(fresh)) == [f"{i:020x}" for i in range(3)]

    filler.unlink()
    again = subprocess.run([*cmd, "--out", str(tmp_path / "t2")], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    with open(tmp_path / "t2.csv", newline="") as fh:
        assert {r["status"] for r in csv.DictReader(fh)} == {"ok"}
    assert len(Archive(root).list_runs()) == 43


# -- 6. damaged segments -------------------------------------------------------------------------


def _chunk_of(ds: h5py.Dataset, index: int) -> tuple[int, int, int]:
    """(file offset, stored size, first element) of the chunk holding element ``index``."""
    assert ds.chunks is not None and ds.ndim == 1
    first = index // ds.chunks[0] * ds.chunks[0]
    info = ds.id.get_chunk_info_by_coord((first,))
    assert info.filter_mask == 0
    return int(info.byte_offset), int(info.size), first


def change_value_in_place(path: Path, dataset: str, index: int) -> float:
    """Change one float64 of ``dataset`` (1-D) by rewriting its bytes in the file, the rest of
    the file untouched (a compressed chunk is re-encoded into its own space). The new value."""
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        assert ds.dtype == np.float64
        old = ds[()]
        if ds.chunks is None:
            offset, size, first, chunk_len = ds.id.get_offset(), old.nbytes, 0, old.size
            encoded = False
        else:
            offset, size, first = _chunk_of(ds, index)
            chunk_len = ds.chunks[0]
            assert ds.compression == "gzip" and ds.shuffle
            encoded = True
    with open(path, "r+b") as fh:
        fh.seek(offset)
        stored = fh.read(size)
        raw = zlib.decompress(stored) if encoded else stored
        planes = np.frombuffer(raw, np.uint8)
        # shuffle stores byte 0 of every element, then byte 1, ...
        values = (planes.reshape(8, chunk_len).T.copy() if encoded else planes.copy()).view(
            np.uint64
        )
        for bit in range(52):  # a mantissa bit whose flip re-encodes into the chunk's space
            changed = values.copy().reshape(-1)
            changed[index - first] ^= np.uint64(1 << bit)
            data = changed.view(np.uint8).reshape(chunk_len, 8).T.tobytes() if encoded else None
            for level in range(9, 0, -1) if encoded else (0,):
                new = zlib.compress(data, level) if data is not None else changed.tobytes()
                if len(new) <= size:
                    fh.seek(offset)
                    fh.write(new)  # any old bytes after the new stream are never read
                    break
            else:
                continue
            break
        else:
            raise AssertionError(f"{path}:{dataset}: no one-bit change fits the chunk's space")
    with h5py.File(path, "r") as f:
        now = f[dataset][()]
    assert now[index] != old[index]
    assert np.delete(now, index).tobytes() == np.delete(old, index).tobytes()
    return float(now[index])


def flip_raw_bytes(path: Path, dataset: str, chunk: int = 0, n: int = 16) -> None:
    """Invert ``n`` bytes in the middle of a stored (compressed) chunk of ``dataset``."""
    with h5py.File(path, "r") as f:
        info = f[dataset].id.get_chunk_info(chunk)
        offset, size = int(info.byte_offset), int(info.size)
    assert size > n + 8
    with open(path, "r+b") as fh:
        fh.seek(offset + size // 2)
        data = fh.read(n)
        fh.seek(offset + size // 2)
        fh.write(bytes(b ^ 0xFF for b in data))


def _distinct_runs(speeds: Sequence[float]) -> list[RunData]:
    runs = []
    for v in speeds:
        scene = _scene(v, terms=True)
        plan = scene.resolve()
        runs.append(RunData(scene, plan, bowlrec.simulate(scene), run_id(plan)))
    return runs


def test_changed_summary_value_is_detected_and_salvaged(tmp_path: Path) -> None:
    """One run's hook changed in place: load() names the run and segment, the segment's other
    runs still load; repair quarantines the segment, keeps (salvages) the other runs, lists the
    damaged run; runs of another segment are untouched."""
    archive = Archive(tmp_path / "a")
    first = _distinct_runs([6.5, 6.8, 7.0, 7.2, 7.5, 7.8])
    second = _distinct_runs([8.0, 8.3, 8.6])
    bad_path = _seal(archive, first)
    _seal(archive, second)
    bad = first[2]
    assert bad.run_id is not None
    bad_segment = bad_path.stem
    assert archive.locate(bad.run_id) == (bad_segment, 2, bad_path)
    change_value_in_place(bad_path, "summary/hook_m", 2)

    with pytest.raises(RunDamagedError) as info:
        archive.load(bad.run_id)
    assert info.value.run_id == bad.run_id and info.value.segment == bad_segment
    assert bad.run_id in str(info.value) and bad_segment in str(info.value)
    for run in first[:2] + first[3:] + second:
        assert run.run_id is not None
        assert_same_trajectory(archive.load(run.run_id).trajectory, run.trajectory)

    report = archive.repair()
    assert report["quarantined_segments"] == [bad_segment]
    assert [(d["run_id"], d["segment_id"]) for d in report["damaged_runs"]] == [
        (bad.run_id, bad_segment)
    ]
    assert not bad_path.exists() and (archive.quarantine_dir / bad_path.name).exists()
    assert [(d["run_id"], d["segment_id"]) for d in archive.damaged()] == [
        (bad.run_id, bad_segment)
    ]
    fresh = Archive(tmp_path / "a")
    for run in first[:2] + first[3:] + second:
        assert run.run_id is not None
        assert_same_trajectory(fresh.load(run.run_id).trajectory, run.trajectory)
    assert bad.run_id not in _listed(fresh)
    with pytest.raises(RunNotFoundError):
        fresh.load(bad.run_id)
    again = fresh.repair()
    assert again["damaged_runs"] == [] and again["quarantined_segments"] == []
    assert len(fresh.list_runs()) == 8


def test_flipped_bytes_in_a_compressed_chunk(tmp_path: Path, template: Template) -> None:
    """Bytes flipped inside a compressed chunk of trajectory/t_s: loading a run stored in that
    chunk raises RunDamagedError (not a raw HDF5 error); runs stored in other chunks load, and
    repair quarantines the segment without losing any run that loaded."""
    archive = Archive(tmp_path / "a")
    n = 200  # enough samples for trajectory/t_s to span several chunks
    path = _seal(archive, [_copy(template, i) for i in range(n)])
    other = _seal(archive, [_copy(template, i) for i in range(1000, 1005)])
    with h5py.File(path, "r") as f:
        ds = f["trajectory/t_s"]
        assert ds.chunks is not None and ds.id.get_num_chunks() >= 2
        chunk_len = ds.chunks[0]
        offsets = f["trajectory/offsets"][()]
    flip_raw_bytes(path, "trajectory/t_s", chunk=0)
    in_chunk = [i for i in range(n) if offsets[i] < chunk_len]
    outside = [i for i in range(n) if offsets[i] >= chunk_len]
    assert in_chunk and outside

    for i in in_chunk:
        with pytest.raises(RunDamagedError) as info:
            archive.load(f"{i:020x}")
        assert info.value.segment == path.stem and f"{i:020x}" in str(info.value)
    for i in outside:
        assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template.run.trajectory)

    report = archive.repair()
    assert report["quarantined_segments"] == [path.stem]
    assert {d["run_id"] for d in report["damaged_runs"]} >= {f"{i:020x}" for i in in_chunk}
    fresh = Archive(tmp_path / "a")
    assert {d["run_id"] for d in fresh.damaged()} >= {f"{i:020x}" for i in in_chunk}
    lost = [i for i in outside if f"{i:020x}" not in _listed(fresh)]
    assert not lost, f"repair set aside {len(lost)} run(s) that loaded fine, e.g. {lost[:3]}"
    for i in outside:
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.run.trajectory)
    for i in range(1000, 1005):
        assert fresh.locate(f"{i:020x}") is not None
        assert fresh.locate(f"{i:020x}")[2] == other  # type: ignore[index]
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.run.trajectory)


def test_truncated_segment_is_reported_by_name(tmp_path: Path, template: Template) -> None:
    """A segment file cut to half its size: load() raises RunDamagedError; repair reports the
    segment by name and quarantines it; runs in other segments load as before."""
    archive = Archive(tmp_path / "a")
    good = _seal(archive, [_copy(template, i) for i in range(5)])
    bad = _seal(archive, [_copy(template, i) for i in range(10, 14)])
    with open(bad, "r+b") as fh:
        fh.truncate(bad.stat().st_size // 2)

    with pytest.raises(RunDamagedError) as info:
        archive.load(f"{10:020x}")
    assert info.value.segment == bad.stem
    report = archive.repair()
    assert report["quarantined_segments"] == [bad.stem]
    assert sorted(d["run_id"] for d in report["damaged_runs"]) == [
        f"{i:020x}" for i in range(10, 14)
    ]
    assert all(d["segment_id"] == bad.stem for d in report["damaged_runs"])
    fresh = Archive(tmp_path / "a")
    assert sorted(_listed(fresh)) == [f"{i:020x}" for i in range(5)]
    assert {d["run_id"] for d in fresh.damaged()} == {f"{i:020x}" for i in range(10, 14)}
    for i in range(5):
        assert fresh.locate(f"{i:020x}")[2] == good  # type: ignore[index]
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.run.trajectory)


def test_simulate_resimulates_a_damaged_copy(tmp_path: Path) -> None:
    """``Archive.simulate(scene)`` whose stored copy is damaged simulates again and stores and
    returns a good run; the damaged copy is listed by damaged()."""
    archive = Archive(tmp_path / "a")
    scene = _scene(7.4, terms=True)
    first = simulate_into(archive, scene)
    assert first.added and first.trajectory is not None
    rid = first.run_id
    old_segment = first.path.stem
    change_value_in_place(first.path, "summary/slide_m", 0)
    with pytest.raises(RunDamagedError):
        archive.load(rid)

    again = simulate_into(archive, scene)
    assert again.run_id == rid
    assert again.added, "the damaged copy was returned instead of a new simulation"
    assert again.trajectory is not None
    want = bowlrec.simulate(scene)
    assert_same_trajectory(again.trajectory, want)
    fresh = Archive(tmp_path / "a")
    assert_same_trajectory(fresh.load(rid).trajectory, want)
    assert _listed(fresh) == [rid]
    assert [(d["run_id"], d["segment_id"]) for d in fresh.damaged()] == [(rid, old_segment)]
    third = simulate_into(fresh, scene)
    assert not third.added and third.trajectory is not None
    assert_same_trajectory(third.trajectory, want)


# -- 7. the index --------------------------------------------------------------------------------


def _library(archive: Archive) -> list[tuple[str, int, str, str, str]]:
    return [
        (e.name, e.version, e.sha, e.added_at, e.note)
        for e in archive.balls.list(all_versions=True)
    ]


def _indexed_archive(root: Path, template: Template) -> Archive:
    archive = Archive(root)
    _seal(archive, [_copy(template, i) for i in range(6)])
    _seal(archive, [_copy(template, i) for i in range(6, 9)])
    ball = template.run.scene.ball
    archive.balls.add("house", ball, note="first")
    archive.balls.add("house", ball.model_copy(update={"mass_kg": 7.0}), note="second")
    archive.balls.add("spare", ball.model_copy(update={"mass_kg": 6.0}))
    archive.remove(f"{4:020x}")
    return archive


def _damage_index(path: Path, damage: str) -> None:
    if damage == "deleted":
        path.unlink()
    else:
        size = path.stat().st_size
        with open(path, "r+b") as fh:  # in place: same file, random bytes
            fh.write(random.Random(7).randbytes(size))


@pytest.mark.parametrize("damage", ["garbled", "deleted"])
def test_damaged_index_rebuilt_for_a_new_process(
    tmp_path: Path, template: Template, damage: str
) -> None:
    """A garbled or deleted index.sqlite: a new process lists the runs and the ball library as
    before (the index rebuilt), the removed run stays removed."""
    root = tmp_path / "a"
    archive = _indexed_archive(root, template)
    runs, library = sorted(_listed(archive)), _library(archive)
    assert len(runs) == 8 and len(library) == 3
    _damage_index(root / "index.sqlite", damage)
    child = _spawn("reader", str(root))
    out, err = child.communicate(timeout=120)
    assert child.returncode == 0, err
    doc = json.loads(out)
    assert sorted(doc["runs"]) == runs
    assert [tuple(b) for b in doc["balls"]] == [lib[:3] for lib in library]
    arrays = {k: v.tobytes().hex() for k, v in template.run.trajectory.arrays().items()}
    assert all(a == arrays for a in doc["loaded"].values())
    assert _library(Archive(root)) == library


@pytest.mark.parametrize("damage", ["garbled", "deleted"])
def test_damaged_index_rebuilt_in_a_process_that_had_it_open(
    tmp_path: Path, template: Template, damage: str
) -> None:
    """The same, in a long-running process that had read the index before it was damaged (a
    service): list_runs and balls.list still work, on a new Archive object and the old one."""
    root = tmp_path / "a"
    archive = _indexed_archive(root, template)
    runs, library = sorted(_listed(archive)), _library(archive)
    _damage_index(root / "index.sqlite", damage)
    fresh = Archive(root)
    assert sorted(_listed(fresh)) == runs
    assert _library(fresh) == library
    assert sorted(_listed(archive)) == runs
    assert _library(archive) == library
    assert_same_trajectory(fresh.load(f"{0:020x}").trajectory, template.run.trajectory)


def test_reindex_while_another_process_reads(tmp_path: Path, template: Template) -> None:
    """A reader listing runs in a loop while the index is rebuilt 12 times (each time with a
    sealed segment more): every count it sees is a whole index, old or new, never partial."""
    root = tmp_path / "a"
    archive = Archive(root)
    _seal(archive, [_copy(template, i) for i in range(30)])
    counts = [30]
    stop = tmp_path / "stop"
    child = _spawn("count", str(root), str(stop))
    try:
        _wait_ready(child)
        next_index = 1000
        for r in range(12):
            n = 5 + 3 * r
            _seal(archive, [_copy(template, next_index + k) for k in range(n)], register=False)
            next_index += n
            counts.append(counts[-1] + n)
            time.sleep(0.05)
            assert archive.reindex() == counts[-1]
            time.sleep(0.05)
    finally:
        stop.touch()
    out, err = _collect(child)
    assert child.returncode == 0, err
    doc = json.loads(out)
    assert doc["n_errors"] == 0, doc["errors"]
    seen: list[int] = doc["counts"]
    assert len(seen) >= 50, "the reader hardly ran"
    odd = sorted(set(seen) - set(counts))
    assert not odd, f"the reader saw partial indexes: counts {odd} (valid: {counts})"
    assert seen == sorted(seen), "the reader saw an older index after a newer one"
    assert len(set(seen)) >= 3, f"the reader saw too few rebuilds to test anything: {set(seen)}"


# -- 8. removal, repair and compaction together ----------------------------------------------


def test_repair_never_salvages_a_removed_run(tmp_path: Path, template: Template) -> None:
    """A segment with a removed run and a damaged one: repair rewrites the healthy runs but not
    the removed one, which stays removed after a rebuild too."""
    archive = Archive(tmp_path / "a")
    path = _seal(archive, [_copy(template, i) for i in range(3)])
    archive.remove(f"{0:020x}")
    change_value_in_place(path, "summary/time_s", 2)
    report = archive.repair(min_age_s=0)
    assert [d["run_id"] for d in report["damaged_runs"]] == [f"{2:020x}"]
    assert _listed(archive) == [f"{1:020x}"]
    assert archive.reindex() == 1 and not archive.has_run(f"{0:020x}")


def test_compaction_leaves_an_unreadable_segment_for_repair(
    tmp_path: Path, template: Template
) -> None:
    archive = Archive(tmp_path / "a")
    paths = [_seal(archive, [_copy(template, i)]) for i in range(3)]
    with open(paths[0], "r+b") as fh:  # the HDF5 signature gone: the file no longer opens
        fh.write(b"\0" * 8)
    report = archive.compact()
    assert report["segments_left"] == 1 and report["runs_moved"] == 2
    assert paths[0].exists() and sorted(_listed(archive)) == [f"{i:020x}" for i in range(3)]
    repaired = archive.repair(min_age_s=0)
    assert [d["run_id"] for d in repaired["damaged_runs"]] == [f"{0:020x}"]
    assert [d["run_id"] for d in archive.damaged()] == [f"{0:020x}"]


def test_compaction_keeps_the_duplicate_of_a_damaged_live_copy(
    tmp_path: Path, template: Template
) -> None:
    """One run sealed by two writers (the second copy a duplicate); the live copy is then
    damaged. Compaction must keep the duplicate, so repair can serve the run from it."""
    archive = Archive(tmp_path / "a")
    live = _seal(archive, [_copy(template, 0), _copy(template, 1)])
    _seal(archive, [_copy(template, 0), _copy(template, 2)])
    assert archive.info()["duplicate_copies"] == 1
    change_value_in_place(live, "summary/time_s", 0)
    archive.compact()
    archive.repair(min_age_s=0)
    for i in range(3):
        assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template.run.trajectory)
    assert archive.reindex() == 3


def test_a_creation_time_copied_from_a_listing_finds_its_run(
    tmp_path: Path, template: Template
) -> None:
    archive = Archive(tmp_path / "a")
    _seal(archive, [_copy(template, 0)])
    created = archive.list_runs()[0]["created_at"]
    assert [r["run_id"] for r in archive.list_runs(where=[f"created_at={created}"])] == [
        f"{0:020x}"
    ]
    assert archive.list_runs(where=[f"created_at>{created}"]) == []


def test_the_in_memory_index_serves_concurrent_threads(tmp_path: Path, template: Template) -> None:
    """A process that may not write lists from an index built in memory; threads share it."""
    from concurrent.futures import ThreadPoolExecutor

    from bowlrec.archive.rebuild import memory_index

    archive = Archive(tmp_path / "a")
    _seal(archive, [_copy(template, i) for i in range(20)])
    (tmp_path / "a" / "index.sqlite").unlink()  # reads fall back to an index in memory
    archive.directory.memory_index = memory_index(archive.directory)

    def work(_: int) -> int:
        return sum(len(archive.list_runs(where=["hook_m>=0"])) for _ in range(50))

    with ThreadPoolExecutor(4) as pool:
        assert list(pool.map(work, range(4))) == [50 * 20] * 4
