"""The rerun sink: .rrd file, read-back, blueprint, entities, live stream, clear errors.

Headless and offline: the real ``rerun`` binary (shipped in ``rerun_cli``, not the Python wrapper
in the venv's bin/) verifies files and, bound to 127.0.0.1, receives the live stream.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
import rerun_cli
from rerun.chunk import RrdReader

import bowlrec
from bowlrec.errors import SamplesRequiredError, ViewerUnavailableError
from bowlrec.sinks import RunData, rerun_recording
from bowlrec.sinks.common import friction_cells, markings_body, quaternion_xyzw
from bowlrec.sinks.rerun_recording import (
    read_rrd_positions,
    read_rrd_series,
    recording_id,
    stream_run,
    write_rrd,
)
from bowlrec.spec import Scene

ROOT = Path(__file__).resolve().parents[1]
RERUN_BIN = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")


def _run(record: str = "rate", record_terms: bool = True) -> RunData:
    """Paper case 16 (non-scalar inertia, CG offset: pin and CG markings), sampled every 10 ms."""
    data = json.loads((ROOT / "examples/paper/case16.json").read_text())
    data["options"].update(record=record, record_dt_s=0.01, record_terms=record_terms)
    scene = Scene.model_validate(data)
    return RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))


@pytest.fixture(scope="module")
def run() -> RunData:
    return _run()


@pytest.fixture(scope="module")
def rrd(run: RunData, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_rrd(run, tmp_path_factory.mktemp("rrd") / "run.rrd")


def _chunks(path: Path) -> list[tuple[str, bool, pa.RecordBatch]]:
    """(entity, is_static, record batch) per chunk of the first recording."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "no footer" warning for received files
        return [(c.entity_path, c.is_static, c.to_record_batch()) for c in RrdReader(path).stream()]


def _entities(path: Path) -> set[str]:
    return {entity for entity, _, _ in _chunks(path)}


def _columns(path: Path, entity: str) -> set[str]:
    return {name for e, _, batch in _chunks(path) if e == entity for name in batch.schema.names}


def _instances(path: Path, entity: str, component: str) -> list[int]:
    """Per row of ``entity``: how many instances of ``component`` it holds."""
    counts: list[int] = []
    for e, _, batch in _chunks(path):
        if e == entity and component in batch.schema.names:
            counts += batch.column(component).value_lengths().to_pylist()
    return counts


def _event_log(path: Path) -> tuple[np.ndarray, list[str]]:
    """(time s, text) of the /events rows, sorted by time."""
    times: list[np.ndarray] = []
    texts: list[str] = []
    for e, _, batch in _chunks(path):
        if e == "/events":
            times.append(batch.column("sim_time").cast(pa.int64()).to_numpy() / 1e9)
            texts += batch.column("TextLog:text").flatten().to_pylist()
    t = np.concatenate(times)
    order = np.argsort(t, kind="stable")
    return t[order], [texts[i] for i in order]


# ----------------------------------------------------------------------------------------------
# file


@pytest.mark.process  # the rerun binary
def test_rrd_verifies_with_the_real_binary(rrd: Path) -> None:
    result = subprocess.run(
        [RERUN_BIN, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert sorted(p.name for p in rrd.parent.iterdir()) == ["run.rrd"]  # no temp file left


def test_read_back_matches_the_trajectory(run: RunData, rrd: Path) -> None:
    traj = run.trajectory
    t, pos = read_rrd_positions(rrd)
    # times: integer nanoseconds on the sim_time duration timeline -> exact to 1 ns
    np.testing.assert_array_equal(np.round(t * 1e9), np.round(traj.t_s * 1e9))
    np.testing.assert_allclose(t, traj.t_s, rtol=0, atol=1e-9)
    # rerun stores translations and quaternions as float32: equal to float32 precision only
    np.testing.assert_allclose(pos, traj.position_m, rtol=1e-6, atol=1e-6)
    tq, quat = read_rrd_series(rrd, "/world/ball", "Transform3D:quaternion")
    np.testing.assert_array_equal(tq, t)
    np.testing.assert_allclose(quat, quaternion_xyzw(traj.quaternion_wxyz), rtol=1e-6, atol=1e-6)
    # the rotation axis starts at the center and points along omega (lane frame)
    _, origins = read_rrd_series(rrd, "/world/rotation_axis", "Arrows3D:origins")
    _, vectors = read_rrd_series(rrd, "/world/rotation_axis", "Arrows3D:vectors")
    np.testing.assert_allclose(origins, traj.position_m, rtol=1e-6, atol=1e-6)
    omega = traj.omega_radps
    expected = 2.5 * run.plan.radius_m * omega / np.linalg.norm(omega, axis=1, keepdims=True)
    np.testing.assert_allclose(vectors, expected, rtol=1e-6, atol=1e-6)
    # scalars are float64: exact
    _, speed = read_rrd_series(rrd, "/plots/speed", "Scalars:scalars")
    np.testing.assert_array_equal(speed[:, 0], traj.speed_mps)
    _, tau = read_rrd_series(rrd, "/plots/torque_components/tau_fric", "Scalars:scalars")
    np.testing.assert_array_equal(tau, traj.torques_Nm["tau_fric"])


def _blueprint_views(path: Path) -> dict[str, tuple[str, str]]:
    """View display name -> (view class, space origin) from the first saved blueprint."""
    reader = RrdReader(path)
    views: dict[str, tuple[str, str]] = {}
    for ch in reader.stream(store=reader.blueprints()[0]):
        batch = ch.to_record_batch()
        if "ViewBlueprint:display_name" in batch.schema.names:
            for name, cls, origin in zip(
                batch.column("ViewBlueprint:display_name").flatten().to_pylist(),
                batch.column("ViewBlueprint:class_identifier").flatten().to_pylist(),
                batch.column("ViewBlueprint:space_origin").flatten().to_pylist(),
                strict=True,
            ):
                views[name] = (cls, origin)
    return views


def test_blueprint_and_recording_ids(run: RunData, rrd: Path) -> None:
    reader = RrdReader(rrd)
    blueprints = reader.blueprints()
    assert blueprints and all(b.application_id == "bowlrec" for b in blueprints)
    views = _blueprint_views(rrd)
    assert views["Lane"] == ("3D", "/world")
    assert views["Ball"] == ("3D", "/world")
    assert views["Events"] == ("TextLog", "/events")
    assert views["Summary"] == ("TextDocument", "/summary")
    assert views["speed [m/s]"] == ("TimeSeries", "/plots/speed")
    assert views["|tau terms| [N m]"] == ("TimeSeries", "/plots/torque_magnitude/tau")
    assert [r.recording_id for r in reader.recordings()] == [recording_id(run)]
    assert recording_id(run).startswith("paper-case16-")
    assert recording_id(RunData(run.scene, run.plan, run.trajectory, "abc123")) == "abc123"


def test_expected_entities(run: RunData, rrd: Path) -> None:
    entities = _entities(rrd)
    expected = {
        "/world",
        "/world/lane",
        "/world/lane/friction",
        "/world/path",
        "/world/ball",
        "/world/ball/markings",
        "/world/ball/pin_axis",
        "/world/rotation_axis",
        "/plots/speed",
        "/plots/rev_rate",
        "/plots/slip_speed",
        "/plots/mu",
        "/plots/normal_force",
        "/plots/torque_magnitude/tau",
        "/plots/torque_magnitude/inertia",
        "/events",
        "/summary",
    }
    expected |= {f"/plots/torque_components/{name}" for name in run.trajectory.torques_Nm}
    assert expected <= entities, expected - entities
    # the ball: static wireframe sphere + temporal transforms; markings are static children
    ball = _columns(rrd, "/world/ball")
    assert {"Ellipsoids3D:half_sizes", "Transform3D:translation", "Transform3D:quaternion"} <= ball
    assert len(markings_body(run.plan)) == 2  # pin and CG side for case 16
    assert _instances(rrd, "/world/ball/markings", "Points3D:positions") == [2]
    assert _instances(rrd, "/world/ball/markings", "Points3D:labels") == [2]
    # one flat box per friction cell; lane, oil pattern and path are static
    cells = _instances(rrd, "/world/lane/friction", "Boxes3D:centers")
    assert cells == [len(friction_cells(run.plan))]
    assert all(
        static for e, static, _ in _chunks(rrd) if e.startswith(("/world/lane", "/world/path"))
    )
    # the rotation axis: one arrow per sample
    assert _instances(rrd, "/world/rotation_axis", "Arrows3D:vectors") == [1] * len(
        run.trajectory.t_s
    )
    # events: one TextLog row per event, at the event times (exact ns)
    events = run.trajectory.events
    t_ev, texts = _event_log(rrd)
    assert len(texts) == len(events) > 0
    np.testing.assert_array_equal(
        np.round(t_ev * 1e9), np.round(np.array([e.t_s for e in events]) * 1e9)
    )
    assert "slide -> roll" in " ".join(texts)


def test_without_torque_terms_there_are_no_torque_plots(tmp_path: Path) -> None:
    run = _run(record_terms=False)
    entities = _entities(write_rrd(run, tmp_path / "plain.rrd"))
    assert "/plots/speed" in entities
    assert not any(e.startswith("/plots/torque") for e in entities)
    views = _blueprint_views(tmp_path / "plain.rrd")
    assert "speed [m/s]" in views and "|tau terms| [N m]" not in views


def test_failed_write_leaves_the_old_file_and_no_temporary(
    run: RunData, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "run.rrd"
    target.write_bytes(b"previous")

    def broken(rec: rr.RecordingStream, run: RunData) -> None:
        rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(rerun_recording, "log_run", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_rrd(run, target)
    assert [p.name for p in tmp_path.iterdir()] == ["run.rrd"]
    assert target.read_bytes() == b"previous"


def test_summary_only_run_raises_and_writes_nothing(tmp_path: Path) -> None:
    run = _run(record="summary", record_terms=False)
    with pytest.raises(SamplesRequiredError, match="rerun recording needs samples"):
        write_rrd(run, tmp_path / "summary.rrd")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(SamplesRequiredError, match="rerun live stream needs samples"):
        stream_run(run, connect_url="rerun+http://127.0.0.1:9/proxy")


def _summary_document(path: Path) -> str:
    """The /summary TextDocument's markdown."""
    texts = [
        text
        for e, _, batch in _chunks(path)
        if e == "/summary"
        for text in batch.column("TextDocument:text").flatten().to_pylist()
    ]
    assert len(texts) == 1
    return str(texts[0])


def test_summary_document_uses_the_cli_units(run: RunData, rrd: Path) -> None:
    s = run.trajectory.summary
    assert s.slide_m is not None and s.hook_m is not None and s.pocket_deg is not None
    text = _summary_document(rrd)
    # the headline and the table give the hook in cm (as `bowlrec simulate`), never in mm
    assert f"hook {100 * s.hook_m:.2f} cm" in text
    assert f"| hook | {100 * s.hook_m:.2f} cm |" in text
    assert re.search(r"\d mm\b", text) is None
    assert f"| slide | {s.slide_m:.3f} m |" in text
    assert f"| pocket angle | {s.pocket_deg:.2f} deg |" in text
    assert f"| time | {s.time_s:.4f} s |" in text
    assert f"| end speed | {s.speed_end_mps:.3f} m/s |" in text
    assert f"| end rev rate | {s.rev_rate_end_rpm:.1f} rpm |" in text
    assert f"| end position | x {s.x_end_m:.3f} m, y {s.y_end_m:.3f} m |" in text


def test_summary_document_of_a_run_that_never_rolls() -> None:
    data = json.loads((ROOT / "examples/paper/case06.json").read_text())
    data["options"].update(record="rate", record_dt_s=0.01)
    scene = Scene.model_validate(data)
    run = RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))
    assert run.trajectory.summary.slide_m is None
    text = rerun_recording._summary_markdown(run)
    assert "| slide | never rolls |" in text
    assert "slide" not in text.splitlines()[2]  # the headline names no slide
    hook = run.trajectory.summary.hook_m
    assert hook is not None and f"| hook | {100 * hook:.2f} cm |" in text


@pytest.mark.process  # a fresh interpreter's modules
def test_sinks_package_does_not_import_rerun() -> None:
    code = "import sys, bowlrec.sinks; print('rerun' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


# ----------------------------------------------------------------------------------------------
# live


def test_spawn_without_display_raises_at_once(
    run: RunData, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    start = time.monotonic()
    with pytest.raises(ViewerUnavailableError, match=r"no display.*\.rrd"):
        stream_run(run, spawn=True)
    assert time.monotonic() - start < 2.0


@pytest.mark.process  # sockets on loopback
def test_connect_to_nothing_raises_at_once(run: RunData) -> None:
    port = _free_port()
    start = time.monotonic()
    with pytest.raises(ViewerUnavailableError, match="no rerun viewer is listening"):
        stream_run(run, connect_url=f"rerun+http://127.0.0.1:{port}/proxy")
    assert time.monotonic() - start < 5.0
    with pytest.raises(ValueError, match="must look like"):
        stream_run(run, connect_url="http://127.0.0.1:9876/")


@pytest.mark.process  # a listening socket on loopback
@pytest.mark.parametrize("reply", [b"SSH-2.0-OpenSSH_9.2\r\n", None])
def test_a_listener_that_is_not_a_viewer_is_refused(
    run: RunData, reply: bytes | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Something else on the port (answers garbage, or accepts and never answers): rerun 0.41
    itself would wait forever on the latter, so the pre-flight check must refuse both."""
    monkeypatch.setattr(rerun_recording, "_PROBE_TIMEOUT_S", 0.5)
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        port = server.getsockname()[1]
        done = threading.Event()

        def serve() -> None:
            conn, _ = server.accept()
            with conn:
                if reply is not None:
                    conn.sendall(reply)
                done.wait(5.0)  # hold the connection open, silent

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        start = time.monotonic()
        with pytest.raises(ViewerUnavailableError, match="no rerun viewer is listening"):
            stream_run(run, connect_url=f"rerun+http://127.0.0.1:{port}/proxy")
        assert time.monotonic() - start < 1.5
        done.set()
        thread.join(5)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_for_port(port: int, proc: subprocess.Popen[bytes], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert proc.poll() is None, "rerun receiver exited early"
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.1)
    raise TimeoutError(f"rerun receiver did not listen on port {port} within {timeout_s} s")


@pytest.fixture
def receiver(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """A headless ``rerun --port P --save recv.rrd`` on 127.0.0.1; killed (the binary) after."""
    port = _free_port()
    out = tmp_path / "recv.rrd"
    env = {**os.environ, "CI": "1"}  # rerun skips its usage analytics on CI
    with (tmp_path / "receiver.log").open("wb") as log:
        proc = subprocess.Popen(
            [RERUN_BIN, "--bind", "127.0.0.1", "--port", str(port), "--save", str(out)],
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )
    try:
        _wait_for_port(port, proc, timeout_s=20.0)
        yield f"rerun+http://127.0.0.1:{port}/proxy", out
    finally:
        # it never exits on client disconnect: kill its process group (only what we started)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)


def _received(path: Path, entities: set[str], n: int, timeout_s: float) -> bool:
    """Poll the receiver's growing file until it holds ``entities`` and n ball positions.

    The receiver writes to disk asynchronously, a little after it got the data.
    """
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if entities <= _entities(path) and len(read_rrd_positions(path)[0]) == n:
                    return True
        except (OSError, KeyError, RuntimeError, ValueError):
            pass  # not (fully) written yet
        time.sleep(0.1)
    return False


@pytest.mark.process  # sockets on loopback
def test_live_stream_reaches_a_headless_receiver(
    run: RunData, rrd: Path, receiver: tuple[str, Path]
) -> None:
    url, out = receiver
    stream_run(run, connect_url=url, timeout_s=30.0)
    expected = _entities(rrd)  # everything the .rrd file of the same run holds
    assert _received(out, expected, run.trajectory.n_samples, timeout_s=15.0), (
        expected - _entities(out) if out.exists() else "no file"
    )
    # the receiver's file has no footer while it runs: RrdReader(...).stream() reads it anyway
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t, pos = read_rrd_positions(out)
        assert [r.recording_id for r in RrdReader(out).recordings()] == [recording_id(run)]
        assert RrdReader(out).blueprints()
    np.testing.assert_allclose(t, run.trajectory.t_s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(pos, run.trajectory.position_m, rtol=1e-6, atol=1e-6)
    verify = subprocess.run(
        [RERUN_BIN, "rrd", "verify", "--check-footers", "false", str(out)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert verify.returncode == 0, verify.stdout + verify.stderr
