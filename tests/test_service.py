"""The HTTP service, talked to with httpx: the whole flow, 422/404 paths and token auth against
the app in process (``helpers.servers.AppServer``); concurrent clients, kill -9 mid-job and
restart, the archive lock and memory against real ``bowlrec serve`` processes on 127.0.0.1."""

from __future__ import annotations

import json
import subprocess
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest

httpx = pytest.importorskip("httpx")
pytest.importorskip("fastapi")
pytest.importorskip("uvicorn")

from helpers.processes import child_command, child_env  # noqa: E402
from helpers.scene_builders import sampled_scene, summary_scene  # noqa: E402
from helpers.servers import AppServer, Server, start_server  # noqa: E402

from bowlrec.archive import Archive  # noqa: E402
from bowlrec.archive.index import INDEX_COLUMNS  # noqa: E402

HERE = Path(__file__).parent


@pytest.fixture(scope="module")
def server(module_app_server: Any) -> AppServer:
    """The service in process: the API's answers do not depend on the transport."""
    return module_app_server()


@pytest.fixture(scope="module")
def client(server: AppServer) -> Iterator[httpx.Client]:
    with server.client() as c:
        yield c


# -- the whole flow ------------------------------------------------------------------------------


def test_submit_scene_then_summary_spec_and_files(
    server: Server, client: httpx.Client, tmp_path: Path
) -> None:
    from bowlrec.sinks.hdf5_run import read_run_file
    from bowlrec.sinks.mcap_file import read_mcap_positions

    r = client.post("/runs", json=sampled_scene())
    assert r.status_code == 201, r.text
    body = r.json()
    rid, summary = body["run_id"], body["summary"]
    assert body["added"] is True and summary["outcome"] == "pins"

    again = client.post("/runs", json={**sampled_scene(), "name": "another name"})
    assert again.status_code == 200
    assert again.json()["run_id"] == rid and again.json()["added"] is False
    # the name is not part of the content ID: the answer names the run as it was archived
    assert again.json()["name"] == body["name"] != "another name"

    row = client.get(f"/runs/{rid[:8]}").json()  # a unique prefix works
    assert row["run_id"] == rid and row["hook_m"] == pytest.approx(summary["hook_m"])
    assert set(row) >= set(INDEX_COLUMNS)

    spec = client.get(f"/runs/{rid}/spec").json()
    assert spec["delivery"]["omega_radps"] == [-16.62, 23.74, 7.765]
    assert client.post("/runs", json=spec).json()["run_id"] == rid  # the spec round-trips

    h5 = client.get(f"/runs/{rid}/files/hdf5")
    assert h5.status_code == 200 and h5.headers["content-type"] == "application/x-hdf5"
    (tmp_path / "run.h5").write_bytes(h5.content)
    stored = read_run_file(tmp_path / "run.h5")
    assert stored.run_id == rid and stored.trajectory.summary.hook_m == summary["hook_m"]

    mcap = client.get(f"/runs/{rid}/files/mcap")
    assert mcap.status_code == 200, mcap.text
    (tmp_path / "run.mcap").write_bytes(mcap.content)
    t, pos, _ = read_mcap_positions(tmp_path / "run.mcap")
    assert np.array_equal(t, stored.trajectory.t_s)
    assert np.array_equal(pos, stored.trajectory.position_m)
    assert client.get(f"/runs/{rid}/files/mcap").content == mcap.content  # cached

    rrd = client.get(f"/runs/{rid}/files/rrd")
    assert rrd.status_code == 200 and rrd.content[:4] == b"RRF2"
    cache = list((server.archive / "cache").rglob("*"))
    assert not [p for p in cache if p.name.endswith(".part")]  # only complete files


def _damage_hook(archive_dir: Path, rid: str) -> None:
    """Change the stored hook of run ``rid`` in place (what a bit flip does)."""
    import h5py

    segment, row, path = Archive(archive_dir, create=False).locate(rid)  # type: ignore[misc]
    with h5py.File(path, "r+") as f:
        hooks = f["summary/hook_m"][()]
        hooks[row] += 1e-6
        f["summary/hook_m"][...] = hooks


def test_a_damaged_run_is_named_never_served(server: Server, client: httpx.Client) -> None:
    scene = sampled_scene()
    scene["delivery"] = {**scene["delivery"], "speed_mps": 8.125}  # a run no other test made
    rid = client.post("/runs", json=scene).json()["run_id"]
    _damage_hook(server.archive, rid)
    assert client.get(f"/runs/{rid}").status_code == 200  # the index row is still listed
    for path in ("spec", "files/hdf5", "files/mcap", "files/rrd"):
        r = client.get(f"/runs/{rid}/{path}")
        assert r.status_code == 409, (path, r.status_code, r.text)
        assert f"run {rid} in segment" in r.json()["detail"] and "damaged" in r.json()["detail"]
    # submitting the scene again stores a fresh copy, which is then served
    again = client.post("/runs", json=scene)
    assert again.status_code == 201 and again.json()["run_id"] == rid
    assert client.get(f"/runs/{rid}/files/hdf5").status_code == 200


def test_bowler_scene_and_library_ball_reference(client: httpx.Client) -> None:
    bowler = json.loads((HERE.parent / "examples" / "bowler" / "house-shot-right.json").read_text())
    bowler["options"] = {"record": "summary"}
    r = client.post("/runs", json=bowler)
    assert r.status_code == 201, r.text

    ball = {"mass_kg": 6.0, "radius_m": 0.1085, "rg_m": [0.07, 0.07, 0.07]}
    assert client.post("/balls", json={"name": "plastic", "spec": ball}).status_code == 201
    r = client.post("/runs", json={**summary_scene(900), "ball": "plastic"})
    assert r.status_code == 201 and r.json()["ball_ref"] == "plastic@1"
    rows = client.get("/runs", params={"ball": "plastic"}).json()["runs"]
    assert [row["run_id"] for row in rows] == [r.json()["run_id"]]


def test_list_and_filter_runs(client: httpx.Client) -> None:
    ids = [client.post("/runs", json=summary_scene(i, "filter")).json()["run_id"] for i in range(6)]
    listed = client.get("/runs", params={"name": "filter"}).json()
    assert listed["count"] == 6 and {r["run_id"] for r in listed["runs"]} == set(ids)

    fast = client.get(
        "/runs",
        params=[
            ("name", "filter"),
            ("where", "speed_mps>=6.002"),
            ("where", "speed_mps<6.005"),
            ("order_by", "-speed_mps"),
        ],
    ).json()["runs"]
    assert [round(r["speed_mps"], 3) for r in fast] == [6.004, 6.003, 6.002]
    one = client.get("/runs", params={"name": "filter", "limit": 1, "outcome": "pins"}).json()
    assert one["count"] == 1
    assert client.get("/runs", params={"pattern": "typical", "name": "filter"}).json()["count"] == 6
    assert client.get("/runs", params={"pattern": "zones", "name": "filter"}).json()["count"] == 0


def test_ball_library_crud(client: httpx.Client) -> None:
    spec = {"mass_kg": 7.0, "radius_m": 0.1085, "rg_m": [0.068, 0.07, 0.07]}
    r = client.post("/balls", json={"name": "crud ball", "spec": spec, "note": "first"})
    assert r.status_code == 201 and r.json()["entry"]["ref"] == "crud ball@1"
    same = client.post("/balls", json={"name": "crud ball", "spec": spec})
    assert same.status_code == 200 and same.json()["added"] is False
    v2 = client.post("/balls", json={"name": "crud ball", "spec": {**spec, "mass_kg": 7.1}})
    assert v2.json()["entry"]["version"] == 2

    assert client.get("/balls/crud ball").json()["version"] == 2
    assert client.get("/balls/crud ball@1").json()["spec"]["mass_kg"] == 7.0
    names = [b["ref"] for b in client.get("/balls", params={"all_versions": True}).json()]
    assert {"crud ball@1", "crud ball@2"} <= set(names)
    export = client.get("/balls/export").json()
    assert export["format"] == "bowlrec-ball-library"
    assert client.post("/balls/import", json=export).json()[0]["added"] is False

    assert client.delete("/balls/crud ball@1").json() == {"removed": "crud ball@1"}
    assert client.get("/balls/crud ball@1").status_code == 404
    assert client.delete("/balls/crud ball@1").status_code == 404
    assert client.delete("/balls/crud ball").status_code == 422  # the version is required


def test_job_submit_and_poll_to_completion(client: httpx.Client) -> None:
    scenes = [summary_scene(i, "job") for i in range(2000, 2030)]
    scenes.append(summary_scene(2000, "job"))  # a duplicate: simulated and archived once
    scenes.append({"ball": {"radius_m": 0.0}})  # invalid: a failure row, not a failed job
    r = client.post("/jobs", json={"name": "thirty", "scenes": scenes})
    assert r.status_code == 202, r.text
    job_id = r.json()["job_id"]
    status = _wait_job(client, job_id, {"done"})
    assert (status["total"], status["done"], status["failed"]) == (32, 31, 1)
    assert status["resumable"] is True  # resuming would retry the failed run
    [failure] = status["failures"]
    assert failure["index"] == 31 and "ball.radius_m" in failure["error"]
    listed = {row["run_id"] for row in client.get("/runs", params={"name": "job"}).json()["runs"]}
    assert set(status["run_ids"]) - {None} == listed and len(listed) == 30
    assert job_id in [j["job_id"] for j in client.get("/jobs").json()]
    assert client.post(f"/jobs/{job_id}/cancel").status_code == 409

    again = client.post("/jobs", json={"name": "again", "scenes": scenes[:30]}).json()
    again = _wait_job(client, again["job_id"], {"done"})
    assert (again["done"], again["skipped"]) == (30, 30)  # all archived: nothing simulated


def test_sweep_job_from_a_bowlrec_job_spec(client: httpx.Client) -> None:
    job = {
        "format": "bowlrec-job",
        "name": "grid",
        "base": {"name": "grid-base"},
        "sweep": {
            "kind": "grid",
            "axes": {
                "delivery.speed_mps": {"start": 7.0, "stop": 8.0, "num": 3},
                "delivery.omega_radps[1]": [20.0, 25.0],
            },
        },
        "record": "summary",
    }
    r = client.post("/jobs", json=job)
    assert r.status_code == 202, r.text
    status = _wait_job(client, r.json()["job_id"], {"done"})
    assert (status["total"], status["done"], status["failed"]) == (6, 6, 0)
    rows = client.get("/runs", params={"name": "grid-base", "order_by": "speed_mps"}).json()
    assert rows["count"] == 6
    assert [round(r["speed_mps"], 3) for r in rows["runs"]][::2] == [7.0, 7.5, 8.0]
    assert {r["record"] for r in rows["runs"]} == {"summary"}


def _wait_job(client: httpx.Client, job_id: str, until: set[str], timeout: float = 60.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = client.get(f"/jobs/{job_id}").json()
        if status["status"] in until:
            return status
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} still {status['status']}: {status}")


# -- 422 and 404 ---------------------------------------------------------------------------------


def test_invalid_specs_get_422_with_field_named_messages(client: httpx.Client) -> None:
    r = client.post("/runs", json={"ball": {"mass_kg": -1.0}, "delivery": {"speed_mps": "fast"}})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "ball.mass_kg: Input should be greater than 0" in detail
    assert "delivery.speed_mps:" in detail

    bowler = client.post("/runs", json={"format": "bowler", "delivery": {"speed_mph": -3}})
    assert bowler.status_code == 422 and "delivery.speed_mph" in bowler.json()["detail"]
    unknown_ball = client.post("/runs", json={"ball": "no-such-ball"})
    assert unknown_ball.status_code == 422 and "no-such-ball" in unknown_ball.json()["detail"]

    bad_path = {"sweep": {"kind": "grid", "axes": {"delivery.nope": [1.0]}}}
    job = client.post("/jobs", json=bad_path)
    assert job.status_code == 422 and "delivery.nope" in job.json()["detail"]
    bad_record = client.post("/jobs", json={"format": "bowlrec-job", "record": "everything"})
    assert bad_record.status_code == 422 and bad_record.json()["detail"].startswith("record:")
    server_file = client.post("/jobs", json={"scenes": ["/etc/passwd"]})
    assert server_file.status_code == 422 and "inline" in server_file.json()["detail"]
    unknown = client.post("/jobs", json={"scenes": [{}], "workers": 3})
    assert unknown.status_code == 422 and unknown.json()["detail"].startswith("workers:")

    bad_ball = client.post("/balls", json={"name": "x", "spec": {"mass_kg": 0}})
    assert bad_ball.status_code == 422 and "spec.mass_kg" in bad_ball.json()["detail"]
    assert client.post("/balls", json={"name": "@bad", "spec": {}}).status_code == 422

    bad_filter = client.get("/runs", params={"where": "nope>1"})
    assert bad_filter.status_code == 422 and "unknown column 'nope'" in bad_filter.json()["detail"]
    assert client.get("/runs", params={"order_by": "nope"}).status_code == 422
    # requests FastAPI cannot parse get the same one-line "where: message" detail
    shape = client.post("/runs", content=b"not json", headers={"content-type": "application/json"})
    assert shape.status_code == 422
    assert shape.json()["detail"] == (
        "request body: not valid JSON at line 1 column 1: Expecting value"
    )
    nan = client.post("/runs", content=b"NaN", headers={"content-type": "application/json"})
    assert nan.status_code == 422
    assert nan.json()["detail"] == "request body: must be a JSON object (got NaN)"
    query = client.get("/runs", params={"limit": "x"})
    assert query.status_code == 422
    assert query.json()["detail"].startswith("query parameter limit: Input should be a valid")


def test_unknown_ids_get_404_and_summary_only_runs_are_re_recorded(
    client: httpx.Client,
) -> None:
    for path in (
        "/runs/0123456789abcdef0123",
        "/runs/zz",
        "/runs/abcdef/spec",
        "/runs/abcdef/files/hdf5",
        "/balls/nothing",
        "/jobs/nope",
    ):
        r = client.get(path)
        assert r.status_code == 404, path
        assert isinstance(r.json()["detail"], str)
    assert client.post("/jobs/nope/resume").status_code == 404
    rid = client.post("/runs", json=summary_scene(77)).json()["run_id"]
    for kind in ("mcap", "rrd"):  # re-recorded from the stored scene
        r = client.get(f"/runs/{rid}/files/{kind}")
        assert r.status_code == 200 and len(r.content) > 1000, kind


def test_health_and_openapi_docs(client: httpx.Client) -> None:
    health = client.get("/health").json()
    assert health["status"] == "ok" and health["auth"] is False
    assert client.get("/docs").status_code == 200
    paths = client.get("/openapi.json").json()["paths"]
    assert {"/runs", "/runs/{run_id}/files/{kind}", "/balls/{ref}", "/jobs/{job_id}"} <= set(paths)


# -- concurrency ---------------------------------------------------------------------------------


@pytest.mark.process
def test_concurrent_clients_every_run_accounted_for(tmp_path: Path) -> None:
    """16 clients x 20 submissions (60 distinct scenes, each submitted ~5 times, concurrently),
    each followed by a read of the run; then the archive holds exactly the distinct runs."""
    n_clients, per_client, distinct = 16, 20, 60
    srv = start_server(tmp_path / "archive")
    seen: list[tuple[int, str, bool]] = []
    lock = threading.Lock()

    def work(c: int) -> None:
        with srv.client() as client:
            for k in range(per_client):
                i = (c * 7 + k * 3) % distinct
                r = client.post("/runs", json=summary_scene(i, "conc"))
                assert r.status_code in (200, 201), r.text
                rid = r.json()["run_id"]
                assert client.get(f"/runs/{rid}").json()["run_id"] == rid
                with lock:
                    seen.append((i, rid, r.json()["added"]))
                if k % 5 == 0:
                    assert client.get("/runs", params={"name": "conc"}).status_code == 200

    try:
        with ThreadPoolExecutor(n_clients) as pool:
            list(pool.map(work, range(n_clients)))
        with srv.client() as client:
            listed = {r["run_id"] for r in client.get("/runs").json()["runs"]}
    finally:
        srv.stop()
    assert len(seen) == n_clients * per_client
    ids_by_scene: dict[int, set[str]] = {}
    for i, rid, _ in seen:
        ids_by_scene.setdefault(i, set()).add(rid)
    assert all(len(ids) == 1 for ids in ids_by_scene.values())  # one content ID per scene
    distinct_ids = {rid for _, rid, _ in seen}
    assert listed == distinct_ids and len(distinct_ids) == len(ids_by_scene)
    assert sum(added for _, _, added in seen) == len(distinct_ids)  # each added exactly once
    archive = Archive(tmp_path / "archive", create=False)
    report = archive.repair()
    assert report["damaged_runs"] == [] and report["index_rows_fixed"] == 0
    assert (report["temporaries_removed"], report["segments_registered"]) == (0, 0)
    assert {r["run_id"] for r in archive.list_runs()} == distinct_ids


# -- kill -9 mid-job and restart -----------------------------------------------------------------


@pytest.mark.fault
def test_kill_mid_job_then_restart_reports_interrupted_and_resumes(tmp_path: Path) -> None:
    archive_dir = tmp_path / "archive"
    srv = start_server(archive_dir)
    # a job long enough (seconds) that the kill lands between two sealed segments
    scenes = [summary_scene(i, "killed") for i in range(5000, 7000)]
    try:
        with srv.client() as client:
            job_id = client.post("/jobs", json={"scenes": scenes}).json()["job_id"]
            deadline = time.monotonic() + 30
            while (status := client.get(f"/jobs/{job_id}").json())["done"] < 10:
                assert time.monotonic() < deadline, status
                time.sleep(0.02)
    finally:
        srv.kill()
    # what was committed when the server died, read straight from the index (read-only)
    before = {r["run_id"] for r in Archive(archive_dir, create=False).list_runs()}
    assert status["status"] == "running" and len(before) >= 10

    srv = start_server(archive_dir)
    try:
        with srv.client() as client:
            after = client.get(f"/jobs/{job_id}").json()
            listed = {r["run_id"] for r in client.get("/runs").json()["runs"]}
            assert before <= listed  # no finished run lost
            assert after["status"] == "interrupted" and after["resumable"] is True
            archived = [rid for rid in after["run_ids"] if rid in listed]
            assert after["done"] == len(archived) >= len(before)
            assert after["done"] < after["total"] == 2000

            resumed = client.post(f"/jobs/{job_id}/resume")
            assert resumed.status_code == 202 and resumed.json()["status"] == "queued"
            final = _wait_job(client, job_id, {"done"})
            assert (final["done"], final["failed"]) == (2000, 0)
            assert final["skipped"] == after["done"]  # archived runs were not simulated again
            listed = {r["run_id"] for r in client.get("/runs").json()["runs"]}
            assert listed == set(final["run_ids"])
    finally:
        srv.stop()
    archive = Archive(archive_dir, create=False)
    repaired = archive.repair()
    assert repaired["damaged_runs"] == [] and len(archive) == 2000


@pytest.mark.process
def test_second_server_on_the_same_archive_is_refused(app_server: Any) -> None:
    """A ``bowlrec serve`` process on an archive whose jobs lock this process's app holds."""
    first = app_server()
    out = subprocess.run(
        child_command("service_child", "--archive", str(first.archive), "--port", "0"),
        capture_output=True,
        text=True,
        env=child_env(),
        timeout=60,
    )
    assert out.returncode == 2 and "another bowlrec server" in out.stderr


# -- auth and binding ----------------------------------------------------------------------------


def test_token_is_required_when_set(app_server: Any) -> None:
    srv = app_server(token="s3cret-token")
    try:
        with srv.client(auth=False) as anon:
            assert anon.get("/health").json()["auth"] is True  # open
            assert anon.get("/docs").status_code == 200  # open
            r = anon.get("/runs")
            assert r.status_code == 401 and r.headers["www-authenticate"] == "Bearer"
            assert anon.post("/runs", json=summary_scene(1)).status_code == 401
            wrong = {"Authorization": "Bearer wrong"}
            assert anon.get("/balls", headers=wrong).status_code == 401
        with srv.client() as client:
            assert client.get("/runs").status_code == 200
            assert client.post("/runs", json=summary_scene(1)).status_code == 201
    finally:
        srv.stop()


def test_non_loopback_host_needs_a_token_or_insecure(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    args = ["serve", "--archive", str(tmp_path / "a"), "--host", "0.0.0.0"]
    out = CliRunner().invoke(app, args)
    assert out.exit_code == 2 and "refusing to serve 0.0.0.0 without a token" in out.output
    assert not (tmp_path / "a").exists()  # refused before touching anything


def test_loopback_detection() -> None:
    from bowlrec.cli.serve import is_loopback

    assert all(map(is_loopback, ["127.0.0.1", "localhost", "::1", "[::1]", "127.0.0.2"]))
    assert not any(map(is_loopback, ["0.0.0.0", "::", "192.168.1.4", "example.org"]))


def _peak_mb(pid: int) -> float:
    """Peak resident memory of a process (VmHWM, MB)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise AssertionError(f"no VmHWM for {pid}")


def test_the_inputs_that_exhausted_the_machine_are_refused_in_bounded_memory(serve: Any) -> None:
    """The inputs a hostile-input campaign found (each took the server past 1-3 GB) are each
    refused with a field-named 4xx, or accepted as a background job and cancelled; the server's
    peak memory grows by less than 100 MB over all of them."""
    server: Server = serve()
    with server.client() as client:
        _refused_in_bounded_memory(server, client)


def _refused_in_bounded_memory(server: Server, client: httpx.Client) -> None:
    client.post("/runs", json={"options": {"record": "summary"}})  # kernels loaded
    before = _peak_mb(server.proc.pid)
    for dt in (1e-300, 1e-8, 1e-6):
        r = client.post("/runs", json={"options": {"record": "rate", "record_dt_s": dt}})
        assert r.status_code == 422 and "record_dt_s" in r.json()["detail"], r.text
    r = client.post("/runs", json={"delivery": {"omega_radps": [0, 1e300, 0]}})
    assert r.status_code == 422 and r.json()["detail"].startswith("delivery.omega_radps[1]: ")
    axis = {"start": 6.0, "stop": 9.0, "num": 10_000}
    grid = {
        "kind": "grid",
        "axes": {"delivery.speed_mps": axis, "delivery.takeoff_angle_deg": axis},
    }
    r = client.post("/jobs", json={"sweep": grid})
    assert r.status_code == 422 and r.json()["detail"].startswith("sweep: 100,000,000 runs")
    speed = {"delivery.speed_mps": {"low": 6.0, "high": 9.0}}
    for n in (10_000_000, 200_000):
        r = client.post(
            "/jobs", json={"sweep": {"kind": "random", "n": n, "seed": 1, "axes": speed}}
        )
        assert r.status_code == 202, r.text
        assert client.post(f"/jobs/{r.json()['job_id']}/cancel").status_code in (200, 202)

    def body() -> Iterator[bytes]:  # 200 MB, chunked (no Content-Length)
        for _ in range(200):
            yield b" " * 2**20

    r = client.post("/runs", content=body(), headers={"content-type": "application/json"})
    assert r.status_code == 413, r.text
    grown = _peak_mb(server.proc.pid) - before
    assert grown < 100, f"the server's peak memory grew by {grown:.0f} MB"
