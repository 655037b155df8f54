"""``bowlrec serve --workers N``: worker processes that simulate in parallel and one supervisor
that writes the archive (group commit), runs the jobs and holds the sessions.

The real-server tests are in the ``process`` tier; the application's use of the shared objects
and the channel's error passing are checked in process (default tier).
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import pytest
from helpers.processes import child_command, child_env
from helpers.scene_builders import summary_scene
from helpers.servers import AppServer, Server, start_server

from bowlrec.archive import Archive
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.errors import BusyError
from bowlrec.service.jobs import JobNotFoundError
from bowlrec.service.security import SessionStore
from bowlrec.service.shared import Shared, WriterGoneError, _portable

TOKEN = "t" * 40


def _workers_of(srv: Server) -> list[int]:
    """The PIDs of the server's worker processes (its spawned children)."""
    try:
        with open(f"/proc/{srv.proc.pid}/task/{srv.proc.pid}/children") as fh:
            children = [int(c) for c in fh.read().split()]
    except OSError:
        return []
    out = []
    for pid in children:
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as fh:
                cmd = fh.read()
        except OSError:
            continue
        if b"spawn_main" in cmd:
            out.append(pid)
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ", 1)[1][0] != "Z"
    except OSError:
        return False


def _wait_for(condition: Any, timeout: float = 60.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def _check_archive(root: Path, run_ids: set[str]) -> None:
    """The archive holds exactly ``run_ids``, each once (index and segments), undamaged."""
    archive = Archive(root, create=False)
    assert {r["run_id"] for r in archive.list_runs()} == run_ids
    info = archive.info()
    assert info["runs"] == len(run_ids) and info["duplicate_copies"] == 0
    report = archive.repair()
    assert report["damaged_runs"] == [] and report["index_rows_fixed"] == 0
    assert (report["temporaries_removed"], report["segments_registered"]) == (0, 0)
    assert report["runs_checked"] == len(run_ids)


# -- in process ----------------------------------------------------------------------------------


class _CountingCommitter(GroupCommitter):
    def __init__(self, archive: Any) -> None:
        super().__init__(archive)
        self.added = 0

    def add(self, record: Any) -> tuple[bool, Path]:
        self.added += 1
        return super().add(record)


def test_app_uses_the_shared_committer_jobs_and_sessions(tmp_path: Path) -> None:
    """An application given ``shared`` hands its summary-only runs to the shared committer and
    answers sessions from the shared store (those of the supervisor in a real server)."""
    archive = Archive(tmp_path / "archive")
    commits = _CountingCommitter(archive).start()
    sessions = SessionStore(60.0)
    from bowlrec.service.jobs import JobManager

    jobs = JobManager(archive)
    srv = AppServer(tmp_path / "archive", TOKEN, {"shared": Shared(commits, jobs, sessions)})
    try:
        with srv.client() as client:
            r = client.post("/runs", json=summary_scene(1, "shared"))
            assert r.status_code == 201 and commits.added == 1
            assert client.post("/runs", json=summary_scene(1, "shared")).json()["added"] is False
            cookie = client.post("/session").cookies["bowlrec_session"]
        assert sessions.valid(cookie)
        with srv.client(auth=False) as client:
            client.cookies.set("bowlrec_session", cookie)
            assert client.get("/runs").status_code == 200
    finally:
        srv.stop()
        commits.close()


def test_errors_cross_the_channel_with_their_category() -> None:
    """An exception raised in the supervisor is raised again in the worker as the same class
    when it pickles, else as the nearest class of its kind (the HTTP status is kept)."""
    err = _portable(JobNotFoundError("no job abc"))
    assert type(err) is JobNotFoundError and str(err) == "no job abc"

    class Unpicklable(BusyError):
        def __init__(self, reason: str, extra: object) -> None:
            super().__init__(reason)
            self.extra = extra

    odd = _portable(Unpicklable("busy", lambda: None))
    assert type(odd) is BusyError and str(odd) == "busy"
    pickle.dumps(odd)
    assert issubclass(WriterGoneError, BusyError)  # 503 with Retry-After


# -- real servers --------------------------------------------------------------------------------


@pytest.mark.process
def test_workers_archive_every_run_exactly_once(tmp_path: Path) -> None:
    """16 clients on 2 worker processes: 40 distinct scenes, each posted by two clients at
    about the same time, plus 5 scenes of its own per client; each run is added exactly once, the
    index and the segments hold every run once, and nothing is damaged."""
    root = tmp_path / "archive"
    srv = start_server(root, None, "--workers", "2")
    n_clients, shared_scenes = 16, 40
    results: list[tuple[int, str, bool]] = []
    lock = threading.Lock()
    barrier = threading.Barrier(n_clients)

    def work(c: int) -> None:
        with srv.client() as client:
            barrier.wait()
            for k in range(shared_scenes // (n_clients // 2)):
                i = (c % (n_clients // 2)) * 100 + k  # clients c and c + 8 post the same scene
                j = 10_000 + c * 100 + k
                for key, scene in ((i, summary_scene(i, "twice")), (j, summary_scene(j, "own"))):
                    r = client.post("/runs", json=scene)
                    assert r.status_code in (200, 201), r.text
                    with lock:
                        results.append((key, r.json()["run_id"], r.json()["added"]))

    try:
        assert len(_workers_of(srv)) == 2
        with ThreadPoolExecutor(n_clients) as pool:
            list(pool.map(work, range(n_clients)))
        with srv.client() as client:
            assert client.get("/health").json()["runs"] == len({r for _, r, _ in results})
    finally:
        srv.stop()
    assert srv.proc.returncode == 130
    by_scene: dict[int, set[str]] = {}
    for key, rid, _ in results:
        by_scene.setdefault(key, set()).add(rid)
    assert all(len(ids) == 1 for ids in by_scene.values())
    run_ids = {rid for _, rid, _ in results}
    assert len(run_ids) == len(by_scene) == shared_scenes + n_clients * 5
    assert sum(added for _, _, added in results) == len(run_ids)  # each added exactly once
    _check_archive(root, run_ids)


@pytest.mark.process
def test_same_scene_from_many_clients_at_once_is_archived_once(tmp_path: Path) -> None:
    """Rounds of 16 clients posting one scene at the same instant, spread over 3 processes:
    one answer says added, all give the same run ID, the segments hold one copy."""
    root = tmp_path / "archive"
    srv = start_server(root, None, "--workers", "3")
    n_clients, rounds = 16, 8
    answers: list[list[tuple[str, bool]]] = [[] for _ in range(rounds)]
    barrier = threading.Barrier(n_clients)

    def work(c: int) -> None:
        with srv.client() as client:
            for k in range(rounds):
                barrier.wait()
                r = client.post("/runs", json=summary_scene(500 + k, "same"))
                assert r.status_code in (200, 201), r.text
                answers[k].append((r.json()["run_id"], r.json()["added"]))

    try:
        with ThreadPoolExecutor(n_clients) as pool:
            list(pool.map(work, range(n_clients)))
    finally:
        srv.stop()
    for got in answers:
        assert len(got) == n_clients and len({rid for rid, _ in got}) == 1
        assert sum(added for _, added in got) == 1
    _check_archive(root, {got[0][0] for got in answers})


@pytest.mark.process
def test_sigterm_answers_what_it_accepted_and_stops_every_process(tmp_path: Path) -> None:
    """SIGTERM while 16 clients post: every run answered 200/201 is archived (by the server
    itself: no segment left for recovery), every process exits, exit status 0."""
    root = tmp_path / "archive"
    srv = start_server(root, None, "--workers", "2")
    workers = _workers_of(srv)
    assert len(workers) == 2
    acknowledged: list[str] = []
    lock = threading.Lock()
    stop = threading.Event()

    def work(c: int) -> None:
        with httpx.Client(base_url=srv.url, timeout=60) as client:
            k = 0
            while not stop.is_set():
                try:
                    r = client.post("/runs", json=summary_scene(20_000 + c * 1000 + k, "term"))
                except httpx.TransportError:
                    return  # the server stopped accepting
                k += 1
                if r.status_code in (200, 201):
                    with lock:
                        acknowledged.append(r.json()["run_id"])
                else:
                    assert r.status_code == 503, r.text

    with ThreadPoolExecutor(16) as pool:
        futures = [pool.submit(work, c) for c in range(16)]
        _wait_for(lambda: len(acknowledged) >= 50, what="50 runs")
        srv.proc.send_signal(signal.SIGTERM)
        srv.proc.wait(60)
        stop.set()
        for f in futures:
            f.result()
    assert srv.proc.returncode == 0, srv.log()
    assert "bowlrec: stopped" in srv.log()
    assert not any(_alive(pid) for pid in workers)
    archive = Archive(root, create=False)
    stored = {r["run_id"] for r in archive.list_runs()}
    assert set(acknowledged) <= stored
    _check_archive(root, stored)


@pytest.mark.process
def test_a_killed_worker_is_reported_and_replaced(tmp_path: Path) -> None:
    """SIGKILL of a worker: the supervisor says which one died and how, starts another, and
    the server keeps answering; Ctrl-C then stops everything (exit 130)."""
    root = tmp_path / "archive"
    srv = start_server(root, None, "--workers", "2")
    try:
        first = _workers_of(srv)
        assert len(first) == 2
        os.kill(first[0], signal.SIGKILL)
        _wait_for(lambda: "died" in srv.log(), what="the report of the death")
        line = next(x for x in srv.log().splitlines() if "died" in x)
        assert f"(pid {first[0]}) died (killed by SIGKILL)" in line
        assert line.startswith("bowlrec: worker process ") and "starting another" in line
        _wait_for(lambda: len(_workers_of(srv)) == 2, what="the new worker")
        assert first[0] not in _workers_of(srv)
        with srv.client() as client:
            for i in range(20):  # new connections land on both processes
                r = client.post("/runs", json=summary_scene(30_000 + i, "after"))
                assert r.status_code == 201, r.text
    finally:
        srv.stop()
    assert srv.proc.returncode == 130 and "bowlrec: stopped" in srv.log()


@pytest.mark.process
def test_workers_share_jobs_sessions_and_the_jobs_lock(tmp_path: Path) -> None:
    """Jobs run in the supervisor and are seen from every worker; a cookie session opened on
    one worker is valid on the others; a second server on the archive is refused; a worker
    whose supervisor is SIGKILLed stops by itself."""
    root = tmp_path / "archive"
    srv = start_server(root, TOKEN, "--workers", "2")
    try:
        with srv.client() as client:
            r = client.post("/jobs", json={"scenes": [summary_scene(i, "job") for i in range(40)]})
            assert r.status_code == 202, r.text
            job_id = r.json()["job_id"]
            _wait_for(
                lambda: client.get(f"/jobs/{job_id}").json()["status"] == "done", what="the job"
            )
            cookie = client.post("/session").cookies["bowlrec_session"]
        for _ in range(12):  # a new connection each: both workers answer
            with srv.client(auth=False) as anonymous:
                anonymous.cookies.set("bowlrec_session", cookie)
                assert anonymous.get(f"/jobs/{job_id}").json()["done"] == 40
        second = subprocess.run(
            [*child_command("service_child"), "--archive", str(root), "--port", "0"]
            + ["--workers", "2"],
            capture_output=True,
            text=True,
            timeout=120,
            env=child_env(),
        )
        assert second.returncode != 0, second.stderr
        assert "another bowlrec server is running the jobs" in second.stderr
        workers = _workers_of(srv)
    finally:
        srv.kill()
    _wait_for(lambda: not any(_alive(pid) for pid in workers), 10, "the orphaned workers")
    assert len(Archive(root, create=False).list_runs()) == 40


@pytest.mark.process  # a Unix socket
def test_the_channel_keeps_507_and_answers_503_when_the_supervisor_is_gone(
    tmp_path: Path,
) -> None:
    """A full disk in the supervisor's committer is 507 in the worker (the message without
    the server's path); a supervisor that stopped answering is 503 with Retry-After."""
    from bowlrec.errors import ArchiveWriteError
    from bowlrec.service.jobs import JobManager
    from bowlrec.service.shared import WriterClient, WriterService

    root = tmp_path / "archive"
    archive = Archive(root)

    class FullDisk:
        def add(self, record: Any) -> tuple[bool, Path]:
            raise ArchiveWriteError(f"{root}/segments: could not write a segment (disk full)")

    service = WriterService(
        {"commits": FullDisk(), "jobs": JobManager(archive), "sessions": SessionStore()}
    )
    client = WriterClient(service.address, service.authkey)
    srv = AppServer(root, None, {"shared": client.shared(60.0)})
    try:
        with srv.client() as http:
            r = http.post("/runs", json=summary_scene(1, "full"))
            assert r.status_code == 507, r.text
            assert r.json()["detail"] == "ARCHIVE/segments: could not write a segment (disk full)"
            assert http.get("/jobs/nope").status_code == 404  # the jobs' errors too
            service.close()
            r = http.post("/runs", json=summary_scene(2, "gone"))
            assert r.status_code == 503 and r.headers["retry-after"] == "1", r.text
            assert "writer process is not answering" in r.json()["detail"]
    finally:
        srv.stop()
        service.close()
