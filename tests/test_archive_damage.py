"""Damaged data in-process (the default tier): a value changed in place, bytes flipped in a
compressed chunk, a truncated segment, a damaged or missing index, a full disk, and removal,
repair and compaction meeting damage. Every damaged run is named, never returned; repair keeps
every healthy run bit for bit.
"""

from __future__ import annotations

import errno
import logging
from collections.abc import Sequence
from pathlib import Path

import h5py
import pytest
from helpers.archive_contract import (
    assert_same_trajectory,
    change_value_in_place,
    copy_of,
    damage_index,
    flip_raw_bytes,
    indexed_archive,
    library,
    listed,
    recorded_scene,
    seal,
    simulated,
)

import bowlrec
from bowlrec.api import simulate_into
from bowlrec.archive import Archive, ArchiveWriteError, RunDamagedError, RunNotFoundError, faults
from bowlrec.sinks import RunData


@pytest.fixture(scope="module")
def template() -> RunData:
    return simulated(recorded_scene())


def _distinct_runs(speeds: Sequence[float]) -> list[RunData]:
    return [simulated(recorded_scene(v, terms=True)) for v in speeds]


def test_changed_summary_value_is_detected_and_salvaged(tmp_path: Path) -> None:
    """One run's hook changed in place: load() names the run and segment, the segment's other
    runs still load; repair quarantines the segment, keeps (salvages) the other runs, lists the
    damaged run; runs of another segment are untouched."""
    archive = Archive(tmp_path / "a")
    first = _distinct_runs([6.5, 6.8, 7.0, 7.2, 7.5, 7.8])
    second = _distinct_runs([8.0, 8.3, 8.6])
    bad_path = seal(archive, first)
    seal(archive, second)
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
    assert bad.run_id not in listed(fresh)
    with pytest.raises(RunNotFoundError):
        fresh.load(bad.run_id)
    again = fresh.repair()
    assert again["damaged_runs"] == [] and again["quarantined_segments"] == []
    assert len(fresh.list_runs()) == 8


def test_flipped_bytes_in_a_compressed_chunk(tmp_path: Path, template: RunData) -> None:
    """Bytes flipped inside a compressed chunk of trajectory/t_s: loading a run stored in that
    chunk raises RunDamagedError (not a raw HDF5 error); runs stored in other chunks load, and
    repair quarantines the segment without losing any run that loaded."""
    archive = Archive(tmp_path / "a")
    n = 200  # enough samples for trajectory/t_s to span several chunks
    path = seal(archive, [copy_of(template, i) for i in range(n)])
    other = seal(archive, [copy_of(template, i) for i in range(1000, 1005)])
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
        assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template.trajectory)

    report = archive.repair()
    assert report["quarantined_segments"] == [path.stem]
    assert {d["run_id"] for d in report["damaged_runs"]} >= {f"{i:020x}" for i in in_chunk}
    fresh = Archive(tmp_path / "a")
    assert {d["run_id"] for d in fresh.damaged()} >= {f"{i:020x}" for i in in_chunk}
    lost = [i for i in outside if f"{i:020x}" not in listed(fresh)]
    assert not lost, f"repair set aside {len(lost)} run(s) that loaded fine, e.g. {lost[:3]}"
    for i in outside:
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.trajectory)
    for i in range(1000, 1005):
        assert fresh.locate(f"{i:020x}") is not None
        assert fresh.locate(f"{i:020x}")[2] == other  # type: ignore[index]
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.trajectory)


def test_truncated_segment_is_reported_by_name(tmp_path: Path, template: RunData) -> None:
    """A segment file cut to half its size: load() raises RunDamagedError; repair reports the
    segment by name and quarantines it; runs in other segments load as before."""
    archive = Archive(tmp_path / "a")
    good = seal(archive, [copy_of(template, i) for i in range(5)])
    bad = seal(archive, [copy_of(template, i) for i in range(10, 14)])
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
    assert sorted(listed(fresh)) == [f"{i:020x}" for i in range(5)]
    assert {d["run_id"] for d in fresh.damaged()} == {f"{i:020x}" for i in range(10, 14)}
    for i in range(5):
        assert fresh.locate(f"{i:020x}")[2] == good  # type: ignore[index]
        assert_same_trajectory(fresh.load(f"{i:020x}").trajectory, template.trajectory)


def test_simulate_resimulates_a_damaged_copy(tmp_path: Path) -> None:
    """``simulate_into(archive, scene)`` whose stored copy is damaged simulates again, stores and
    returns a good run; the damaged copy is listed by damaged()."""
    archive = Archive(tmp_path / "a")
    scene = recorded_scene(7.4, terms=True)
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
    assert listed(fresh) == [rid]
    assert [(d["run_id"], d["segment_id"]) for d in fresh.damaged()] == [(rid, old_segment)]
    third = simulate_into(fresh, scene)
    assert not third.added and third.trajectory is not None
    assert_same_trajectory(third.trajectory, want)


@pytest.mark.parametrize("damage", ["garbled", "deleted"])
def test_a_damaged_index_is_read_from_the_data_files_then_rebuilt_by_a_write(
    tmp_path: Path, template: RunData, damage: str, caplog: pytest.LogCaptureFixture
) -> None:
    """A garbled or deleted index.sqlite in a long-running process that had read it before (a
    service): list_runs, balls.list and load work on the old Archive object and a new one,
    from an index built in memory (with a warning naming `runs reindex`); reading leaves the
    file as it is; the next write rebuilds it; the removed run stays removed throughout."""
    root = tmp_path / "a"
    archive = indexed_archive(root, template)
    runs, balls = sorted(listed(archive)), library(archive)
    assert len(runs) == 8 and len(balls) == 3
    index = root / "index.sqlite"
    damage_index(index, damage)
    damaged = index.read_bytes() if index.exists() else None
    fresh = Archive(root)
    with caplog.at_level(logging.WARNING, logger="bowlrec.archive"):
        assert sorted(listed(fresh)) == runs
    assert "runs reindex" in caplog.text
    assert library(fresh) == balls
    assert sorted(listed(archive)) == runs
    assert library(archive) == balls
    assert_same_trajectory(fresh.load(f"{0:020x}").trajectory, template.trajectory)
    assert (index.read_bytes() if index.exists() else None) == damaged  # reads never write
    fresh.balls.add("third", template.scene.ball.model_copy(update={"mass_kg": 5.5}))
    assert index.exists() and index.read_bytes() != damaged
    assert sorted(listed(Archive(root))) == runs and len(library(Archive(root))) == 4


def test_a_full_disk_loses_nothing(tmp_path: Path, template: RunData) -> None:
    """No space while a segment is written (replayed in-process; test_archive_processes.py
    fills a real small file system): one ArchiveWriteError line, no temporary left, every run
    archived before loads, and adding works again once there is space."""
    archive = Archive(tmp_path / "a")
    for i in range(3):
        assert archive.add(copy_of(template, i), wall_time_s=0.0).added

    def disk_full(**_context: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    with faults.armed("segment-written", disk_full):
        with pytest.raises(ArchiveWriteError) as info:
            archive.add(copy_of(template, 10), wall_time_s=0.0)
        with pytest.raises(ArchiveWriteError):
            simulate_into(archive, recorded_scene(7.3))
    message = str(info.value)
    assert "\n" not in message and "No space left on device" in message
    assert "nothing already archived was lost" in message
    assert not list((tmp_path / "a").rglob("*.part"))
    assert sorted(listed(archive)) == [f"{i:020x}" for i in range(3)]
    for i in range(3):
        assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template.trajectory)
    assert archive.add(copy_of(template, 10), wall_time_s=0.0).added
    assert simulate_into(archive, recorded_scene(7.3)).added and len(archive) == 5


def test_repair_never_salvages_a_removed_run(tmp_path: Path, template: RunData) -> None:
    """A segment with a removed run and a damaged one: repair rewrites the healthy runs but not
    the removed one, which stays removed after a rebuild too."""
    archive = Archive(tmp_path / "a")
    path = seal(archive, [copy_of(template, i) for i in range(3)])
    archive.remove(f"{0:020x}")
    change_value_in_place(path, "summary/time_s", 2)
    report = archive.repair(min_age_s=0)
    assert [d["run_id"] for d in report["damaged_runs"]] == [f"{2:020x}"]
    assert listed(archive) == [f"{1:020x}"]
    assert archive.reindex() == 1 and not archive.has_run(f"{0:020x}")


def test_compaction_leaves_an_unreadable_segment_for_repair(
    tmp_path: Path, template: RunData
) -> None:
    archive = Archive(tmp_path / "a")
    paths = [seal(archive, [copy_of(template, i)]) for i in range(3)]
    with open(paths[0], "r+b") as fh:  # the HDF5 signature gone: the file no longer opens
        fh.write(b"\0" * 8)
    report = archive.compact()
    assert report["segments_left"] == 1 and report["runs_moved"] == 2
    assert paths[0].exists() and sorted(listed(archive)) == [f"{i:020x}" for i in range(3)]
    repaired = archive.repair(min_age_s=0)
    assert [d["run_id"] for d in repaired["damaged_runs"]] == [f"{0:020x}"]
    assert [d["run_id"] for d in archive.damaged()] == [f"{0:020x}"]


def test_compaction_keeps_the_duplicate_of_a_damaged_live_copy(
    tmp_path: Path, template: RunData
) -> None:
    """One run sealed by two writers (the second copy a duplicate); the live copy is then
    damaged. Compaction must keep the duplicate, so repair can serve the run from it."""
    archive = Archive(tmp_path / "a")
    live = seal(archive, [copy_of(template, 0), copy_of(template, 1)])
    seal(archive, [copy_of(template, 0), copy_of(template, 2)])
    assert archive.info()["duplicate_copies"] == 1
    change_value_in_place(live, "summary/time_s", 0)
    archive.compact()
    archive.repair(min_age_s=0)
    for i in range(3):
        assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template.trajectory)
    assert archive.reindex() == 3


def test_a_creation_time_copied_from_a_listing_finds_its_run(
    tmp_path: Path, template: RunData
) -> None:
    archive = Archive(tmp_path / "a")
    seal(archive, [copy_of(template, 0)])
    created = archive.list_runs()[0]["created_at"]
    assert [r["run_id"] for r in archive.list_runs(where=[f"created_at={created}"])] == [
        f"{0:020x}"
    ]
    assert archive.list_runs(where=[f"created_at>{created}"]) == []


def test_the_in_memory_index_serves_concurrent_threads(tmp_path: Path, template: RunData) -> None:
    """A process that may not write lists from an index built in memory; threads share it."""
    from concurrent.futures import ThreadPoolExecutor

    from bowlrec.archive.rebuild import memory_index

    archive = Archive(tmp_path / "a")
    seal(archive, [copy_of(template, i) for i in range(20)])
    (tmp_path / "a" / "index.sqlite").unlink()  # reads fall back to an index in memory
    archive.directory.memory_index = memory_index(archive.directory)

    def work(_: int) -> int:
        return sum(len(archive.list_runs(where=["hook_m>=0"])) for _ in range(50))

    with ThreadPoolExecutor(4) as pool:
        assert list(pool.map(work, range(4))) == [50 * 20] * 4
