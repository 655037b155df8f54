"""One bad job record never disables the service: records under ``ARCHIVE/jobs/`` are
validated when the server starts, and a record that is invalid, truncated or missing (or a
job whose spec is missing) is listed with status ``damaged`` and a one-line reason; start-up,
``GET /jobs`` and ``GET /jobs/ID`` keep working and cancel/resume of such a job is 409."""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from fastapi.testclient import TestClient  # noqa: E402

from bowlrec.archive import Archive  # noqa: E402
from bowlrec.service.app import create_app  # noqa: E402
from bowlrec.service.jobs import JobManager  # noqa: E402


def _jobs(archive_dir: Path, n: int) -> list[str]:
    """``n`` queued jobs persisted by a manager that never runs them (then stopped: they are
    ``interrupted`` on disk, as after a server stop)."""
    manager = JobManager(Archive(archive_dir))
    manager.open()
    ids = [
        manager.submit({"name": f"job{i}", "scenes": [{"delivery": {"speed_mps": 7.5 + i}}]}).job_id
        for i in range(n)
    ]
    manager.stop()
    return ids


def _record(archive_dir: Path, job_id: str) -> Path:
    return archive_dir / "jobs" / f"{job_id}.json"


def _edit(**changes: Any) -> Callable[[Path, str], None]:
    def edit(archive_dir: Path, job_id: str) -> None:
        path = _record(archive_dir, job_id)
        data = json.loads(path.read_text())
        data.update(changes)
        path.write_text(json.dumps(data))

    return edit


def _write(text: str) -> Callable[[Path, str], None]:
    def write(archive_dir: Path, job_id: str) -> None:
        _record(archive_dir, job_id).write_text(text)

    return write


def _truncate(archive_dir: Path, job_id: str) -> None:
    path = _record(archive_dir, job_id)
    path.write_bytes(path.read_bytes()[:40])


def _delete_record(archive_dir: Path, job_id: str) -> None:
    _record(archive_dir, job_id).unlink()


def _delete_spec(archive_dir: Path, job_id: str) -> None:
    (archive_dir / "jobs" / f"{job_id}.spec.json").unlink()


def _binary_runs_file(archive_dir: Path, job_id: str) -> None:
    (archive_dir / "jobs" / f"{job_id}.runs").write_bytes(b"\xff\xfe0 \x00\x00garbage\n")


#: (damage, expected reason fragment)
DAMAGE: dict[str, tuple[Callable[[Path, str], None], str]] = {
    "unknown-status": (_edit(status="exploded"), "status: Input should be"),
    "string-total": (_edit(total="5"), "total: Input should be a valid integer"),
    "huge-total": (_edit(total=10**15), "total: Input should be less than or equal"),
    "negative-done": (_edit(done=-1), "done: Input should be greater than or equal to 0"),
    "failures-null": (_edit(failures=None), "failures: Input should be a valid"),
    "bad-failure-row": (_edit(failures=[{"index": "x"}]), "failures.0.index"),
    "other-job-id": (_edit(job_id="0123abcd"), "names another job (0123abcd)"),
    "truncated": (_truncate, "Invalid JSON"),
    "empty": (_write(""), "Invalid JSON"),
    "not-an-object": (_write("null"), "Input should be an object"),
    "a-list": (_write("[1, 2]"), "Input should be an object"),
    "record-deleted": (_delete_record, "is missing (its spec is left)"),
    "spec-deleted": (_delete_spec, ".spec.json is missing"),
}


@pytest.fixture
def client_for() -> Iterator[Callable[[Path], TestClient]]:
    """Start the service on an archive (the lifespan runs: records are loaded and the job
    thread starts) and stop it after the test."""
    clients: list[TestClient] = []

    def start(archive_dir: Path) -> TestClient:
        app = create_app(archive_dir, warm_up=False)
        client = TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False)
        client.__enter__()
        clients.append(client)
        return client

    yield start
    for client in clients:
        client.__exit__(None, None, None)


@pytest.mark.parametrize("case", sorted(DAMAGE))
def test_a_damaged_job_is_listed_never_fatal(
    tmp_path: Path,
    client_for: Callable[[Path], TestClient],
    caplog: pytest.LogCaptureFixture,
    case: str,
) -> None:
    archive_dir = tmp_path / "archive"
    bad, good = _jobs(archive_dir, 2)
    damage, reason = DAMAGE[case]
    damage(archive_dir, bad)

    with caplog.at_level(logging.WARNING, logger="bowlrec.service.jobs"):
        client = client_for(archive_dir)  # start-up survives the bad record
    assert any(bad in r.getMessage() and "damaged" in r.getMessage() for r in caplog.records)

    listed = client.get("/jobs")
    assert listed.status_code == 200, listed.text
    by_id = {j["job_id"]: j for j in listed.json()}
    assert set(by_id) == {bad, good}
    assert by_id[good]["status"] == "interrupted" and by_id[good]["resumable"] is True
    damaged = by_id[bad]
    assert damaged["status"] == "damaged" and damaged["resumable"] is False
    assert reason in damaged["error"], damaged["error"]
    assert "\n" not in damaged["error"] and str(tmp_path) not in damaged["error"]

    one = client.get(f"/jobs/{bad}")
    assert one.status_code == 200 and one.json()["status"] == "damaged"
    assert one.json()["error"] == damaged["error"]
    for action in ("cancel", "resume"):
        r = client.post(f"/jobs/{bad}/{action}")
        assert r.status_code == 409, r.text
        detail = r.json()["detail"]
        assert f"job {bad} is damaged and cannot be" in detail and "\n" not in detail

    # the other job and new ones are unaffected
    assert client.get(f"/jobs/{good}").json()["run_ids"] == [None]
    new = client.post("/jobs", json={"name": "new", "scenes": [{"name": "n"}]})
    assert new.status_code == 202, new.text
    assert client.post(f"/jobs/{new.json()['job_id']}/cancel").status_code in (202, 409)


def test_the_damaged_name_comes_from_what_is_readable(
    tmp_path: Path, client_for: Callable[[Path], TestClient]
) -> None:
    archive_dir = tmp_path / "archive"
    from_record, from_spec, orphan_runs = _jobs(archive_dir, 3)
    _edit(status="?")(archive_dir, from_record)
    _truncate(archive_dir, from_spec)
    _delete_record(archive_dir, orphan_runs)
    _delete_spec(archive_dir, orphan_runs)
    (archive_dir / "jobs" / f"{orphan_runs}.runs").write_text("0 abc\n")
    client = client_for(archive_dir)
    by_id = {j["job_id"]: j for j in client.get("/jobs").json()}
    assert by_id[from_record]["name"] == "job0" and by_id[from_record]["total"] == 1
    assert by_id[from_spec]["name"] == "job1"
    assert by_id[orphan_runs]["name"] == "" and by_id[orphan_runs]["status"] == "damaged"
    assert "only its runs file" in by_id[orphan_runs]["error"]


def test_legacy_and_odd_but_valid_records_still_load(
    tmp_path: Path, client_for: Callable[[Path], TestClient]
) -> None:
    """``"run_ids": null`` (a key older records kept inline) with status ``running``: the
    server starts and reports the job interrupted; a runs file with binary junk is read as far
    as it is readable."""
    archive_dir = tmp_path / "archive"
    legacy, junk = _jobs(archive_dir, 2)
    _edit(run_ids=None, status="running")(archive_dir, legacy)
    _binary_runs_file(archive_dir, junk)
    client = client_for(archive_dir)
    job = client.get(f"/jobs/{legacy}")
    assert job.status_code == 200 and job.json()["status"] == "interrupted"
    assert job.json()["run_ids"] == [None]
    r = client.get(f"/jobs/{junk}")
    assert r.status_code == 200 and r.json()["run_ids"] == [None]
    assert [j["status"] for j in client.get("/jobs").json()] == ["interrupted"] * 2
    # the record was rewritten valid
    assert json.loads(_record(archive_dir, legacy).read_text())["status"] == "interrupted"


def test_every_job_file_damaged_at_once(
    tmp_path: Path, client_for: Callable[[Path], TestClient]
) -> None:
    archive_dir = tmp_path / "archive"
    ids = _jobs(archive_dir, len(DAMAGE))
    for job_id, (damage, _) in zip(ids, DAMAGE.values(), strict=True):
        damage(archive_dir, job_id)
    (archive_dir / "jobs" / "notes.json").write_text("{}")  # a stray file
    client = client_for(archive_dir)
    listed = client.get("/jobs")
    assert listed.status_code == 200
    statuses = {j["job_id"]: j["status"] for j in listed.json()}
    assert {statuses[i] for i in ids} == {"damaged"} and statuses["notes"] == "damaged"
    assert client.get("/health").status_code == 200


def test_a_job_whose_record_cannot_be_written_is_not_queued(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A full disk while a job is submitted: 507, and nothing is left behind (no job listed as
    queued forever, no spec file for a restart to list as damaged)."""
    from bowlrec.errors import ArchiveWriteError

    def full(self: JobManager, rec: Any, durable: bool = True) -> None:
        raise ArchiveWriteError("could not write the record (No space left on device)")

    monkeypatch.setattr(JobManager, "_persist", full)
    app = create_app(tmp_path / "a", warm_up=False)
    with TestClient(app, base_url="http://127.0.0.1") as client:
        r = client.post("/jobs", json={"scenes": [{"delivery": {"speed_mps": 7.5}}]})
        assert r.status_code == 507, r.text
        assert client.get("/jobs").json() == []
    assert list((tmp_path / "a" / "jobs").glob("*.spec.json")) == []
