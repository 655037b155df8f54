"""Crashes replayed in-process at the write path's named fault points (bowlrec/archive/faults.py):
mid-write of a segment, sealed but not registered, inside the index transaction, a group commit,
a removal, a compaction, a repair and an index rebuild. After each: nothing already archived is
lost or changed (every run loads bit for bit), reads before the next writer see the index as it
was (reads never write), and the next writer (a new Archive: a new process, as far as the
archive can tell) recovers and says what it did. Real kills (a flock released by the OS, a hot
SQLite journal) are in test_archive_faults.py.
"""

from __future__ import annotations

import logging
import os
import shutil
import threading
import time
from pathlib import Path

import pytest
from helpers.archive_contract import (
    SimulatedCrash,
    assert_same_trajectory,
    change_value_in_place,
    copy_of,
    crash_at,
    listed,
    recorded_scene,
    seal,
    simulated,
    snapshot,
)

from bowlrec.archive import Archive, faults
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.errors import RunDamagedError
from bowlrec.sinks import RunData


@pytest.fixture(scope="module")
def template() -> RunData:
    return simulated(recorded_scene())


def _ids(*ranges: range) -> list[str]:
    return sorted(f"{i:020x}" for r in ranges for i in r)


def _archived(root: Path, template: RunData) -> tuple[Archive, list[str]]:
    """Runs 0-4 and 10-12 in two segments, run 20 added on its own."""
    archive = Archive(root)
    seal(archive, [copy_of(template, i) for i in range(5)])
    seal(archive, [copy_of(template, i) for i in range(10, 13)])
    archive.add(copy_of(template, 20), wall_time_s=0.0)
    return archive, _ids(range(5), range(10, 13), range(20, 21))


def _intact(root: Path, template: RunData, ids: list[str]) -> Archive:
    """A new Archive lists exactly ``ids``, each loading bit for bit; a repair then finds no
    damage and leaves no temporary. The new Archive."""
    fresh = Archive(root)
    assert sorted(listed(fresh)) == ids
    for rid in ids:
        assert_same_trajectory(fresh.load(rid).trajectory, template.trajectory, rid)
    report = fresh.repair(min_age_s=0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == [], report
    assert not list(root.rglob("*.part")) and sorted(listed(fresh)) == ids
    return fresh


def _leave_a_dead_copy(path: Path, age_s: float = 10.0) -> Path:
    """What a real kill leaves of a file being written: an unlocked temporary (a copy of
    ``path`` named as one), ``age_s`` old."""
    dead = path.with_name(f".{path.name.lstrip('.')}.dead.part")
    shutil.copy(path, dead)
    old = time.time() - age_s
    os.utime(dead, (old, old))
    return dead


# -- writing one segment -------------------------------------------------------------------------


def test_a_crash_mid_write_of_a_segment(
    tmp_path: Path, template: RunData, caplog: pytest.LogCaptureFixture
) -> None:
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    left: list[Path] = []

    def leave(path: Path) -> None:
        left.append(_leave_a_dead_copy(path))

    with crash_at("segment-written", leave), pytest.raises(SimulatedCrash):
        archive.add(copy_of(template, 30), wall_time_s=0.0)
    assert left and left[0].exists()
    assert not list(root.glob("segments/*.h5.????????.part")), "the writer's own temporary"
    assert sorted(listed(Archive(root))) == ids

    nxt = Archive(root)
    with caplog.at_level(logging.INFO, logger="bowlrec.archive"):
        assert nxt.add(copy_of(template, 31), wall_time_s=0.0).added
    assert not left[0].exists()
    assert "removed 1 temporaries" in caplog.text
    assert nxt.recover()["temporaries_removed"] == 1  # reported to the explicit call too
    _intact(root, template, sorted([*ids, f"{31:020x}"]))


def test_a_crash_between_sealing_and_registering(tmp_path: Path, template: RunData) -> None:
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    with crash_at("sealed"), pytest.raises(SimulatedCrash):
        archive.add(copy_of(template, 30), wall_time_s=0.0)
    before = snapshot(root)
    reader = Archive(root)
    assert sorted(listed(reader)) == ids and not reader.has_run(f"{30:020x}")
    assert snapshot(root) == before, "a read registered the sealed segment"

    nxt = Archive(root)
    assert nxt.add(copy_of(template, 31), wall_time_s=0.0).added  # its first write recovers
    assert nxt.recover()["segments_registered"] == 1
    _intact(root, template, sorted([*ids, f"{30:020x}", f"{31:020x}"]))


def test_a_crash_inside_the_index_transaction(tmp_path: Path, template: RunData) -> None:
    """Rows inserted, the transaction not committed: the index keeps what it had (rolled
    back); the sealed segments are registered by the next writer."""
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    infos = []
    for first in (30, 40):
        builder = archive.builder()
        for i in range(first, first + 4):
            builder.append(archive.record(copy_of(template, i), wall_time_s=0.0))
        infos.append(archive.seal(builder))
    with crash_at("registering"), pytest.raises(SimulatedCrash):
        archive.register(infos)
    assert sorted(listed(archive)) == ids and sorted(listed(Archive(root))) == ids
    assert not (root / "index.sqlite-journal").exists()

    assert Archive(root).recover()["segments_registered"] == 2
    _intact(root, template, sorted([*ids, *_ids(range(30, 34), range(40, 44))]))


def test_a_crash_in_a_group_commit(tmp_path: Path, template: RunData) -> None:
    """Every thread waiting on the crashed commit hears of it (none is told its run was
    archived); the committer goes on committing; the next writer registers the sealed group."""
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    group = GroupCommitter(archive).start()
    records = [archive.record(copy_of(template, 30 + i), wall_time_s=0.0) for i in range(6)]
    outcomes: list[BaseException | tuple[bool, Path] | None] = [None] * 6
    barrier = threading.Barrier(6)

    def hand_over(i: int) -> None:
        barrier.wait()
        try:
            outcomes[i] = group.add(records[i])
        except BaseException as err:  # noqa: BLE001 - the test inspects it
            outcomes[i] = err

    try:
        with crash_at("group-commit-sealed"):
            threads = [threading.Thread(target=hand_over, args=(i,)) for i in range(6)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
        crashed = [o for o in outcomes if isinstance(o, SimulatedCrash)]
        committed = [o for o in outcomes if isinstance(o, tuple)]
        assert len(crashed) + len(committed) == 6 and crashed, outcomes
        assert all(added for added, _ in committed)  # only a commit after the crash
        late = archive.record(copy_of(template, 40), wall_time_s=0.0)
        assert group.add(late)[0]
    finally:
        group.close()
    assert Archive(root).recover()["segments_registered"] >= 1
    _intact(root, template, sorted([*ids, *_ids(range(30, 36), range(40, 41))]))


# -- removal ---------------------------------------------------------------------------------


def test_a_crash_after_the_tombstone_is_written(tmp_path: Path, template: RunData) -> None:
    """The tombstone file is durable before the index changes: the run stays listed until the
    next writer applies it, and never comes back after."""
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    gone = f"{11:020x}"
    with crash_at("tombstone-written"), pytest.raises(SimulatedCrash):
        archive.remove(gone)
    assert gone in listed(Archive(root))  # reads apply nothing

    nxt = Archive(root)
    assert nxt.recover()["tombstone_files_applied"] == 1
    left = [rid for rid in ids if rid != gone]
    assert sorted(listed(nxt)) == left
    assert nxt.reindex() == len(left) and gone not in listed(nxt)
    nxt.compact()
    _intact(root, template, left)


# -- compaction ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "point", ["compaction-sealed", "compaction-switched", "compaction-deleted"]
)
def test_a_crash_mid_compaction(tmp_path: Path, template: RunData, point: str) -> None:
    """Six one-run segments, two runs removed, a compaction crashed at ``point``: every live
    run loads as before, the removed ones never come back (not after recovery, a rebuild or
    the compaction run again)."""
    root = tmp_path / "a"
    archive = Archive(root)
    ids = [f"{i:020x}" for i in range(6)]
    for i in range(6):
        archive.add(copy_of(template, i), wall_time_s=0.0)
    archive.remove(ids[0])
    archive.remove(ids[1])
    live = ids[2:]
    with crash_at(point), pytest.raises(SimulatedCrash):
        archive.compact()
    reader = Archive(root)
    assert sorted(listed(reader)) == live
    for rid in live:
        assert_same_trajectory(reader.load(rid).trajectory, template.trajectory, rid)

    nxt = Archive(root)
    nxt.recover()
    assert sorted(listed(nxt)) == live
    assert nxt.reindex() == len(live) and sorted(listed(nxt)) == live
    report = nxt.compact()
    assert report["segments_left"] == 0
    assert len(list((root / "segments").glob("*.h5"))) == 1
    assert nxt.info()["duplicate_copies"] == 0
    _intact(root, template, live)


# -- repair ------------------------------------------------------------------------------------


@pytest.mark.parametrize("point", ["repair-salvaged", "repair-quarantined"])
def test_a_crash_mid_repair(tmp_path: Path, template: RunData, point: str) -> None:
    """A segment with one damaged run, repaired; the repair crashed at ``point``. The next
    writer's recovery finishes an index switch the crash left undone; a repair after it
    leaves every healthy run loading bit for bit and the damaged one listed damaged."""
    root = tmp_path / "a"
    archive = Archive(root)
    bad = seal(archive, [copy_of(template, i) for i in range(4)])
    seal(archive, [copy_of(template, i) for i in range(10, 12)])
    change_value_in_place(bad, "summary/hook_m", 1)
    damaged = f"{1:020x}"
    healthy = _ids(range(0, 1), range(2, 4), range(10, 12))
    with crash_at(point), pytest.raises(SimulatedCrash):
        archive.repair(min_age_s=0)
    assert sorted(listed(Archive(root))) == sorted([*healthy, damaged])  # the index as it was

    nxt = Archive(root)
    recovered = nxt.recover()
    assert recovered["repairs_finished"] == (point == "repair-quarantined")
    for rid in healthy:
        assert_same_trajectory(nxt.load(rid).trajectory, template.trajectory, rid)
    if point == "repair-salvaged":
        with pytest.raises(RunDamagedError):
            nxt.load(damaged)
        assert nxt.repair(min_age_s=0)["quarantined_segments"] == [bad.stem]
    assert not bad.exists() and (root / "quarantine" / bad.name).exists()
    assert [d["run_id"] for d in nxt.damaged()] == [damaged]
    assert sorted(listed(nxt)) == healthy
    nxt.compact()
    fresh = _intact(root, template, healthy)
    assert fresh.reindex() == len(healthy) and [d["run_id"] for d in fresh.damaged()] == [damaged]


# -- the index ---------------------------------------------------------------------------------


def test_a_crash_while_rebuilding_the_index(tmp_path: Path, template: RunData) -> None:
    """The new index written beside the old one, not yet renamed: the old index stays whole;
    the leftover a real kill leaves is deleted by the next rebuild."""
    root = tmp_path / "a"
    archive, ids = _archived(root, template)
    index = root / "index.sqlite"
    before = index.read_bytes()
    left: list[Path] = []

    def leave(path: Path) -> None:
        left.append(path.with_name("index.sqlite.rebuild-deadbeef"))
        shutil.copy(path, left[0])

    with crash_at("index-rebuilt", leave), pytest.raises(SimulatedCrash):
        archive.reindex()
    assert index.read_bytes() == before and sorted(listed(Archive(root))) == ids
    assert left[0].exists()
    assert Archive(root).reindex() == len(ids)
    assert not list(root.glob("index.sqlite.rebuild-*"))
    _intact(root, template, ids)


def test_fault_points_are_named_and_disarmed() -> None:
    with pytest.raises(ValueError, match="no fault point 'nowhere'"):
        crash_at("nowhere").__enter__()
    with crash_at("sealed"), pytest.raises(RuntimeError, match="armed already"):
        crash_at("sealed").__enter__()
    faults.point("sealed")  # disarmed again: a no-op
