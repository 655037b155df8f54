"""The server's writer process: group commits sealed and registered in a child process, the
same runs archived as in the committer thread, a dead writer reported and replaced."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, run_id
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.archive.segment_format import RunRecord
from bowlrec.core.solver import run_plan
from bowlrec.errors import ArchiveWriteError
from bowlrec.service.writer import WriterProcess
from bowlrec.sinks.common import RunData
from bowlrec.spec import Scene

pytestmark = pytest.mark.process  # a writer process is a child process


def _scene(i: int) -> Scene:
    return Scene.model_validate(
        {
            "name": f"w{i}",
            "delivery": {"speed_mps": 6.0 + 0.01 * i},
            "options": {"record": "summary"},
        }
    )


def _records(archive: Archive, ids: range) -> list[RunRecord]:
    out = []
    for i in ids:
        scene = _scene(i)
        plan = scene.resolve()
        run = RunData(scene, plan, run_plan(plan, "auto"), run_id(plan))
        out.append(archive.record(run, wall_time_s=1e-3, solver="closed_form"))
    return out


@pytest.fixture
def archive(tmp_path: Path) -> Archive:
    return Archive(tmp_path / "a")


@pytest.fixture
def writer(archive: Archive) -> Iterator[WriterProcess]:
    started = WriterProcess(archive.root).start()
    try:
        yield started
    finally:
        started.close()


def test_a_group_is_committed_in_the_writer_process(
    archive: Archive, writer: WriterProcess
) -> None:
    records = _records(archive, range(5))
    pid = writer.pid()
    assert pid is not None and pid != os.getpid()
    first = writer([*records, records[0]])  # the same run twice in one group
    again = writer(records)
    assert [added for added, _ in first] == [True] * 5 + [False]
    paths = {path for _, path in first}
    assert len(paths) == 1 and next(iter(paths)).exists()  # one segment
    assert again == [(False, path) for _, path in first[:5]]
    for r in records:
        stored = archive.load(r.run_id).trajectory.summary
        assert stored == r.summary
    assert archive.repair()["damaged_runs"] == []


def test_a_killed_writer_fails_its_group_and_a_new_one_takes_the_next(
    archive: Archive, writer: WriterProcess
) -> None:
    records = _records(archive, range(4))
    pid = writer.pid()
    assert pid is not None
    os.kill(pid, signal.SIGKILL)
    with pytest.raises(ArchiveWriteError, match="writer process stopped"):
        writer(records[:2])
    assert all(added for added, _ in writer(records[2:]))
    assert writer.pid() not in (None, pid)
    assert archive.locate(records[2].run_id) is not None
    assert archive.locate(records[3].run_id) is not None
    # the killed writer's group was not archived; submitted again, it is
    assert all(archive.locate(r.run_id) is None for r in records[:2])


def test_after_close_a_group_is_committed_in_this_process(
    archive: Archive, writer: WriterProcess
) -> None:
    writer.close()
    [(added, path)] = writer(_records(archive, range(1)))
    assert added and path is not None and writer.pid() is None


def test_concurrent_requests_share_the_writers_segments(
    tmp_path: Path, archive: Archive, writer: WriterProcess
) -> None:
    group = GroupCommitter(archive, commit=writer).start()
    results: list = [None] * 16  # type: ignore[type-arg]
    barrier = threading.Barrier(16)

    def work(i: int) -> None:
        barrier.wait()
        results[i] = simulate_into(archive, _scene(i), group=group)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(16)]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        group.close()
    assert all(r.added for r in results) and group.committed_runs == 16
    segments = list((tmp_path / "a" / "segments").glob("*.h5"))
    assert len(segments) == group.commits < 16
    for r in results:
        assert archive.load(r.run_id).trajectory.summary == r.trajectory.summary
