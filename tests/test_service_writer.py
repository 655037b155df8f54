"""The server's writer process: group commits sealed and registered in a child process, the
same runs archived as in the committer thread, a dead writer reported and replaced."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path

import pytest

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, run_id
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.archive.segment_format import RunRecord
from bowlrec.core.solver import run_plan
from bowlrec.errors import ArchiveWriteError
from bowlrec.service import writer as writer_module
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


def _dead(pid: int) -> bool:
    """Whether process ``pid`` has exited (gone, or a zombie not reaped yet)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state in ("Z", "X")


@pytest.fixture
def archive(tmp_path: Path) -> Archive:
    return Archive(tmp_path / "a")


@pytest.fixture
def writer(archive: Archive) -> Iterator[WriterProcess]:
    started = WriterProcess(archive.directory).start()
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


def test_a_writer_found_dead_is_replaced_before_the_group_is_handed_over(
    archive: Archive, writer: WriterProcess
) -> None:
    records = _records(archive, range(4))
    pid = writer.pid()
    assert pid is not None
    os.kill(pid, signal.SIGKILL)
    # once the pool has seen its process die, it refuses the group before anything is handed
    # over (a group handed over in the moment before it saw that fails with 507 instead)
    deadline = time.monotonic() + 10
    while not (_dead(pid) and writer._pool is not None and writer._pool._broken):  # type: ignore[attr-defined]
        assert time.monotonic() < deadline, "the pool did not see its process die"
        time.sleep(0.02)
    assert all(added for added, _ in writer(records))
    assert writer.pid() not in (None, pid)
    assert all(archive.locate(r.run_id) is not None for r in records)


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


class _StuckPool(ProcessPoolExecutor):
    """A pool whose process has died while its group's result never arrives (what a writer
    killed halfway through sending its result leaves behind)."""

    def __init__(self) -> None:
        super().__init__(max_workers=1)
        self.dead = False

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def, override]
        return Future()  # never completes


def test_a_writer_that_dies_mid_commit_fails_its_group_instead_of_hanging(
    archive: Archive, monkeypatch: pytest.MonkeyPatch
) -> None:
    stuck = _StuckPool()
    writer = WriterProcess(archive.directory)
    monkeypatch.setattr(writer, "_new_pool", lambda: stuck)
    monkeypatch.setattr(writer_module, "POLL_S", 0.01)
    died = {"now": False}
    monkeypatch.setattr(writer_module, "pool_died", lambda pool: died["now"])
    result: list[BaseException] = []

    def commit() -> None:
        try:
            writer(_records(archive, range(1)))
        except ArchiveWriteError as err:
            result.append(err)

    thread = threading.Thread(target=commit, daemon=True)  # daemon: a failing test must not hang
    thread.start()
    time.sleep(0.2)
    assert thread.is_alive()  # waiting for the writer, which is alive
    died["now"] = True
    thread.join(timeout=10)
    assert not thread.is_alive() and "stopped during a commit" in str(result[0])
    stuck.shutdown(wait=False)


def test_the_app_commits_posted_runs_in_its_writer_process(tmp_path: Path) -> None:
    from fastapi.testclient import TestClient

    from bowlrec.service import create_app

    app = create_app(tmp_path / "a", warm_up=False, writer_process=True)
    scene = _scene(1).model_dump(mode="json")
    with TestClient(app, base_url="http://127.0.0.1") as client:  # a loopback Host
        writer = app.state.bowlrec.writer
        first = client.post("/runs", json=scene)
        assert first.status_code == 201 and first.json()["added"]
        pid = writer.pid()
        assert pid is not None and pid != os.getpid()
        again = client.post("/runs", json=scene)
        assert again.status_code == 200 and again.json()["run_id"] == first.json()["run_id"]
        assert not again.json()["added"]
    assert writer.pid() is None  # stopped with the app
    assert Archive(tmp_path / "a").locate(first.json()["run_id"]) is not None
