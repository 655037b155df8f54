"""The archive under real kills (the ``fault`` tier): writers killed with SIGKILL at random
moments, alone and several at once, and a writer killed inside its SQLite transaction. What
only a real kill shows: the writer lock's flock released by the OS, a temporary left locked
and then unlocked, the rollback journal SQLite plays back. The same moments replayed
in-process are in test_archive_fault_points.py (the default tier).

Child processes: tests/archive_fault_child.py. The heavy variant is also marked ``slow``.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from helpers.archive_contract import (
    Template,
    assert_same_trajectory,
    collect,
    copy_of,
    ids_in_segment_files,
    listed,
    make_template,
    seal,
    spawn,
    temporaries,
    wait_ready,
)

from bowlrec.archive import Archive

pytestmark = pytest.mark.fault


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Template:
    return make_template(tmp_path_factory.mktemp("template"))


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
    return spawn("writer", str(root), str(template.path), str(start), str(stop), str(seed))


def _kill(child: subprocess.Popen[str]) -> WriterOutput:
    with contextlib.suppress(ProcessLookupError):
        os.kill(child.pid, signal.SIGKILL)
    out, err = collect(child)
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
    shown = listed(archive)
    assert len(shown) == len(set(shown)), "a run is listed twice"
    reported = {rid for w in outputs for rid in w.reported}
    missing = (reported | archived) - set(shown)
    assert not missing, f"{len(missing)} reported run(s) not listed, e.g. {sorted(missing)[:3]}"
    allowed = reported | archived | {rid for w in outputs for rid in w.in_flight}
    strays = set(shown) - allowed
    assert not strays, f"runs nobody wrote: {sorted(strays)[:3]}"
    new = sorted(reported - archived)
    to_load = new if loads is None else rng.sample(new, min(len(new), loads))
    to_load += rng.sample(sorted(archived), min(len(archived), 10))
    for rid in to_load:
        assert_same_trajectory(archive.load(rid).trajectory, template.run.trajectory, rid)

    report = archive.repair(min_age_s=0)
    assert temporaries(root) == []
    assert report["damaged_runs"] == [], report
    assert report["quarantined_segments"] == [], report
    assert archive.damaged() == []
    in_files = ids_in_segment_files(root)
    after = listed(archive)
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
        wait_ready(child)
        time.sleep(rng.uniform(0.02, 0.25))
        w = _kill(child)
        phases.append(w.phase)
        parts_left += bool(temporaries(root))
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
            wait_ready(c)
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
def test_sigkill_campaign_heavy(tmp_path: Path, template: Template) -> None:
    """Heavy variant: 20 kills with every reported run loaded, 4 concurrent rounds."""
    _kill_campaign(tmp_path / "a", template, kills=20, concurrent_rounds=4, loads=None, seed=2)


# -- 2. a writer killed inside its index transaction ------------------------------------------

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
    seal(archive, [copy_of(template.run, i) for i in range(400)])  # pages the COMMIT rewrites
    before = sorted(listed(archive))
    child = spawn("die-in-commit", str(root), str(template.path), "1000", "400")
    out, err = child.communicate(timeout=120)
    assert child.returncode == -signal.SIGKILL and out.strip() == "killing", err
    journal = root / "index.sqlite-journal"
    assert journal.exists() and journal.read_bytes()[:8] == JOURNAL_MAGIC, "no hot journal"

    # a reader may see the killed writer's sealed segment registered by a recovery, or not
    killed = sorted(f"{i:020x}" for i in range(1000, 1400))
    valid = (before, sorted(before + killed))
    assert sorted(listed(archive)) in valid  # the connection this process had open
    assert sorted(listed(Archive(root))) in valid
    for rid in before[:3]:
        assert_same_trajectory(archive.load(rid).trajectory, template.run.trajectory)
    reader = spawn("reader", str(root))
    out, err = reader.communicate(timeout=120)
    assert reader.returncode == 0, err
    assert sorted(json.loads(out)["runs"]) in valid

    report = Archive(root).repair(min_age_s=0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == [], report
    after = listed(Archive(root))
    assert sorted(after) == sorted(set(ids_in_segment_files(root)))
    assert len(after) == 800 and not journal.exists()
