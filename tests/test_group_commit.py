"""Group commit: runs added from many threads are sealed together, each reported once."""

from __future__ import annotations

import errno
import threading
from pathlib import Path

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, faults
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.errors import ArchiveWriteError
from bowlrec.spec import Scene


def _scene(i: int) -> Scene:
    return Scene.model_validate(
        {
            "name": f"g{i}",
            "delivery": {"speed_mps": 6.0 + 0.01 * i},
            "options": {"record": "summary"},
        }
    )


def _run_threads(n: int, fn) -> list:  # type: ignore[no-untyped-def, type-arg]
    out: list = [None] * n  # type: ignore[type-arg]
    barrier = threading.Barrier(n)

    def work(i: int) -> None:
        barrier.wait()
        out[i] = fn(i)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return out


def test_concurrent_runs_share_segments_and_all_are_indexed(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    group = GroupCommitter(archive).start()
    try:
        results = _run_threads(24, lambda i: simulate_into(archive, _scene(i), group=group))
    finally:
        group.close()
    assert all(r.added for r in results)
    assert group.committed_runs == 24
    assert group.commits < 24  # runs that waited together were sealed together
    segments = list((tmp_path / "a" / "segments").glob("*.h5"))
    assert len(segments) == group.commits
    for r in results:
        assert archive.locate(r.run_id) is not None and r.path.exists()
        assert archive.load(r.run_id).trajectory.summary == r.trajectory.summary
    assert archive.repair()["damaged_runs"] == []


def test_the_same_scene_from_many_threads_is_added_once(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    group = GroupCommitter(archive).start()
    try:
        results = _run_threads(12, lambda i: simulate_into(archive, _scene(0), group=group))
    finally:
        group.close()
    assert sum(r.added for r in results) == 1
    assert len({r.run_id for r in results}) == 1
    assert archive.info()["runs"] == 1 and archive.info()["duplicate_copies"] == 0


def test_a_failed_write_reaches_every_waiter_and_loses_nothing(tmp_path: Path) -> None:
    """A full disk while the group's segment is written: every waiting thread gets the one
    ArchiveWriteError, no temporary is left, the run archived before stays."""
    archive = Archive(tmp_path / "a")
    kept = simulate_into(archive, _scene(100))
    group = GroupCommitter(archive).start()

    def disk_full(**_context: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    try:
        with faults.armed("segment-written", disk_full):
            errors = _run_threads(
                6, lambda i: _error(lambda: simulate_into(archive, _scene(i), group=group))
            )
    finally:
        group.close()
    assert all(isinstance(e, ArchiveWriteError) for e in errors), errors
    assert "No space left on device" in str(errors[0])
    assert not list((tmp_path / "a").rglob("*.part"))
    assert archive.has_run(kept.run_id) and archive.info()["runs"] == 1


def _error(fn):  # type: ignore[no-untyped-def]
    try:
        fn()
    except Exception as err:  # noqa: BLE001 - the test inspects it
        return err
    return None


def test_recorded_runs_are_not_grouped(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    group = GroupCommitter(archive).start()
    scene = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.01}})
    try:
        res = simulate_into(archive, scene, group=group)
    finally:
        group.close()
    assert res.added and group.commits == 0
    late = simulate_into(archive, _scene(5), group=group)  # after close: committed on its own
    assert late.added and archive.has_run(late.run_id)


def test_a_committer_never_started_starts_on_first_use(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    group = GroupCommitter(archive)
    try:
        assert simulate_into(archive, _scene(7), group=group).added and group.commits == 1
    finally:
        group.close()
