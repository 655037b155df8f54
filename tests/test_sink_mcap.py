"""The MCAP sink: exact round trips, CRC-checked reads, schemas, records, atomic writes, batches.

Headless and offline: files are read back with the mcap reader (CRC validation on) and checked
by the real ``rerun`` binary shipped in ``rerun_cli`` (``rerun mcap check`` / ``convert``).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun_cli
from mcap.decoder import DecoderFactory
from mcap.reader import NonSeekingReader, make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory
from rerun.chunk import RrdReader

import bowlrec
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import SamplesRequiredError
from bowlrec.paper import paper_scene
from bowlrec.sinks import RunData
from bowlrec.sinks import mcap_file as mf
from bowlrec.sinks.common import body_to_lane, friction_cells, markings_body
from bowlrec.spec import Scene

SINGLE_TOPICS = ("/tf", "/scene", "/ball/state", "/events")


def _run(scene: Scene) -> RunData:
    return RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))


def _rate(scene: Scene, *, terms: bool) -> Scene:
    options = scene.options.model_copy(
        update={"record": "rate", "record_dt_s": 0.01, "record_terms": terms}
    )
    return scene.model_copy(update={"options": options})


@pytest.fixture(scope="module")
def run() -> RunData:
    """Default scene (oil then dry, 3 events), per-term torques recorded, ~250 samples."""
    return _run(_rate(Scene.model_validate({"name": "default"}), terms=True))


@pytest.fixture(scope="module")
def run16() -> RunData:
    """Paper case 16: non-scalar inertia and a mass offset (pin and cg markings), no terms."""
    return _run(_rate(paper_scene(16), terms=False))


@pytest.fixture(scope="module")
def mcap_path(run: RunData, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return mf.write_mcap(run, tmp_path_factory.mktemp("mcap") / "run.mcap")


@pytest.fixture(scope="module")
def mcap16(run16: RunData, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return mf.write_mcap(run16, tmp_path_factory.mktemp("mcap16") / "case16.mcap")


class _JsonDecoderFactory(DecoderFactory):
    """mcap 1.6 ships no JSON decoder."""

    def decoder_for(self, message_encoding: str, schema: Any) -> Any:
        return json.loads if message_encoding == "json" else None


def _decoded(path: Path, topic: str) -> list[tuple[int, Any]]:
    """(log_time, decoded message) of ``topic``, reading with chunk CRC validation."""
    factories = [ProtobufDecoderFactory(), _JsonDecoderFactory()]
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=factories)
        return [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(topics=[topic])]


def _schemas(path: Path) -> dict[str, tuple[str, str, dict[str, Any] | None]]:
    """topic -> (message encoding, schema name, JSON schema or None)."""
    with open(path, "rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None
    out = {}
    for ch in summary.channels.values():
        schema = summary.schemas[ch.schema_id]
        body = json.loads(schema.data) if schema.encoding == "jsonschema" else None
        out[ch.topic] = (ch.message_encoding, schema.name, body)
    return out


def _log_ns(t_s: Any) -> Any:
    return np.rint(np.asarray(t_s) * 1e9).astype(np.int64)


# ---------------------------------------------------------------- a small JSON-schema checker
# (jsonschema is not a dependency; this covers the subset the sink's schemas use)


def _validate(value: Any, schema: dict[str, Any], where: str = "$") -> None:
    kind = schema.get("type")
    if kind == "object":
        assert isinstance(value, dict), where
        props = schema.get("properties", {})
        for key in schema.get("required", []):
            assert key in value, f"{where}: missing {key}"
        if schema.get("additionalProperties") is False:
            assert set(value) <= set(props), f"{where}: extra {set(value) - set(props)}"
        for key, sub in props.items():
            if key in value:
                _validate(value[key], sub, f"{where}.{key}")
    elif kind == "number":
        assert isinstance(value, int | float) and not isinstance(value, bool), where
    elif kind == "string":
        assert isinstance(value, str), where
    else:
        raise AssertionError(f"{where}: schema type {kind!r} not handled by this checker")
    if "enum" in schema:
        assert value in schema["enum"], f"{where}: {value!r} not in {schema['enum']}"


def _leaves(schema: dict[str, Any], path: str = "") -> Iterator[tuple[str, dict[str, Any]]]:
    """Top-level and torque-term fields (the ones that carry a description with units)."""
    for key, sub in schema["properties"].items():
        if key == "torques_Nm":
            yield from ((f"torques_Nm.{k}", s) for k, s in sub["properties"].items())
        else:
            yield f"{path}{key}", sub


# ---------------------------------------------------------------- (1) exact round trip


def test_tf_round_trips_exactly(run: RunData, mcap_path: Path) -> None:
    traj = run.trajectory
    msgs = _decoded(mcap_path, "/tf")
    assert len(msgs) == traj.n_samples
    pos = np.array([[m.translation.x, m.translation.y, m.translation.z] for _, m in msgs])
    quat = np.array([[m.rotation.w, m.rotation.x, m.rotation.y, m.rotation.z] for _, m in msgs])
    assert np.array_equal(pos, traj.position_m)  # float64 equality, no tolerance
    assert np.array_equal(quat, traj.quaternion_wxyz)
    assert {(m.parent_frame_id, m.child_frame_id) for _, m in msgs} == {("lane", "ball")}
    log_ns = np.array([t for t, _ in msgs])
    stamps = np.array([m.timestamp.seconds * 10**9 + m.timestamp.nanos for _, m in msgs])
    assert np.array_equal(log_ns, _log_ns(traj.t_s))
    assert np.array_equal(stamps, log_ns)
    assert log_ns[0] == 0  # epoch 0: log time is simulated time


def test_read_mcap_positions_is_exact(run: RunData, mcap_path: Path) -> None:
    t, pos, quat = mf.read_mcap_positions(mcap_path)
    assert np.array_equal(t, run.trajectory.t_s)
    assert np.array_equal(pos, run.trajectory.position_m)
    assert np.array_equal(quat, run.trajectory.quaternion_wxyz)


# ---------------------------------------------------------------- (2) full CRC pass


def test_full_crc_pass_counts_messages_per_channel(run: RunData, mcap_path: Path) -> None:
    counts: Counter[str] = Counter()
    with open(mcap_path, "rb") as f:  # checks every chunk CRC and the data-section CRC
        reader = NonSeekingReader(f, validate_crcs=True)
        for _, channel, _ in reader.iter_messages(log_time_order=False):
            counts[channel.topic] += 1
    n = run.trajectory.n_samples
    expected = {"/tf": n, "/ball/state": n, "/scene": 1, "/events": len(run.trajectory.events)}
    assert dict(counts) == expected
    with open(mcap_path, "rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == sum(expected.values())
    assert summary.statistics.metadata_count == 2
    assert summary.statistics.attachment_count == 1


def test_schemas_are_foxglove_well_known_and_json(mcap_path: Path) -> None:
    schemas = _schemas(mcap_path)
    assert set(schemas) == set(SINGLE_TOPICS)
    assert schemas["/tf"][:2] == ("protobuf", "foxglove.FrameTransform")
    assert schemas["/scene"][:2] == ("protobuf", "foxglove.SceneUpdate")
    assert schemas["/ball/state"][:2] == ("json", "bowlrec.BallState")
    assert schemas["/events"][:2] == ("json", "bowlrec.Event")


# ---------------------------------------------------------------- (3) external validator


def _rerun_binary() -> str:
    """The real rerun binary shipped in ``rerun_cli`` (not the Python wrapper in bin/)."""
    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    assert os.access(exe, os.X_OK), exe
    return exe


@pytest.mark.process  # the rerun binary
def test_rerun_mcap_check_passes(mcap_path: Path) -> None:
    done = subprocess.run(
        [_rerun_binary(), "mcap", "check", str(mcap_path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    for topic in SINGLE_TOPICS:
        assert any(
            line.split()[:1] == ["ok"] and topic in line.split()
            for line in done.stdout.splitlines()
        ), done.stdout


@pytest.mark.process  # the rerun binary
def test_rerun_convert_turns_tf_into_transform3d(
    run: RunData, mcap_path: Path, tmp_path: Path
) -> None:
    rrd = tmp_path / "run.rrd"
    done = subprocess.run(
        [_rerun_binary(), "mcap", "convert", str(mcap_path), "-o", str(rrd)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    rows: list[Any] = []
    for chunk in RrdReader(str(rrd)).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == "/tf" and "Transform3D:translation" in batch.schema.names:
            rows += batch.column("Transform3D:translation").to_pylist()
    translation = np.array(rows, dtype=np.float64).reshape(-1, 3)
    # rerun stores float32
    np.testing.assert_allclose(translation, run.trajectory.position_m, rtol=1e-6, atol=1e-6)


# ---------------------------------------------------------------- (4) state channel


def test_state_messages_validate_against_their_schema(run: RunData, mcap_path: Path) -> None:
    traj = run.trajectory
    schema = _schemas(mcap_path)["/ball/state"][2]
    assert schema == mf.state_schema(traj)
    msgs = [m for _, m in _decoded(mcap_path, "/ball/state")]
    assert len(msgs) == traj.n_samples
    for m in msgs:
        _validate(m, schema)
    for name, sub in _leaves(schema):
        if sub["type"] != "string":
            assert "[" in sub["description"] and "]" in sub["description"], f"{name}: no units"
    # per-term torques present, exactly as recorded
    assert set(schema["properties"]["torques_Nm"]["properties"]) == set(traj.torques_Nm)
    for term, arr in traj.torques_Nm.items():
        got = np.array([[m["torques_Nm"][term][k] for k in "xyz"] for m in msgs])
        assert np.array_equal(got, arr), term


def test_state_values_are_exact(run: RunData, mcap_path: Path) -> None:
    traj = run.trajectory
    msgs = [m for _, m in _decoded(mcap_path, "/ball/state")]

    def vec(name: str, keys: str = "xyz") -> Any:
        return np.array([[m[name][k] for k in keys] for m in msgs])

    def col(name: str) -> Any:
        return np.array([m[name] for m in msgs])

    assert np.array_equal(col("t_s"), traj.t_s)
    assert np.array_equal(vec("velocity_mps"), traj.velocity_mps)
    assert np.array_equal(vec("quaternion_wxyz", "wxyz"), traj.quaternion_wxyz)
    assert np.array_equal(vec("omega_radps"), traj.omega_radps)
    assert np.array_equal(vec("alpha_radps2"), traj.alpha_radps2)
    assert np.array_equal(vec("slip_mps"), traj.slip_mps)
    assert np.array_equal(vec("friction_force_N"), traj.friction_force_N)
    assert np.array_equal(col("mu"), traj.mu)
    assert np.array_equal(col("normal_force_N"), traj.normal_force_N.reshape(-1))
    assert np.array_equal(col("energy_J"), traj.energy_J)
    assert np.array_equal(col("speed_mps"), traj.speed_mps)
    rpm = np.linalg.norm(traj.omega_radps, axis=1) * 60.0 / (2.0 * math.pi)
    assert np.array_equal(col("rev_rate_rpm"), rpm)
    assert np.array_equal(col("slip_speed_mps"), np.linalg.norm(traj.slip_mps, axis=1))
    assert list(col("phase")) == ["rolling" if p else "sliding" for p in traj.phase]
    assert {"sliding", "rolling"} == set(col("phase"))


def test_no_torques_without_record_terms(run16: RunData, mcap16: Path) -> None:
    assert not run16.trajectory.torques_Nm
    schema = _schemas(mcap16)["/ball/state"][2]
    assert schema is not None and "torques_Nm" not in schema["properties"]
    for _, m in _decoded(mcap16, "/ball/state"):
        _validate(m, schema)
        assert "torques_Nm" not in m


def test_state_messages_refuse_non_finite_values(run: RunData) -> None:
    bad = run.trajectory.energy_J.copy()
    bad[3] = np.nan
    fields = {k: getattr(run.trajectory, k) for k in Trajectory.__dataclass_fields__}
    traj = Trajectory(**{**fields, "energy_J": bad})
    with pytest.raises(ValueError, match="energy_J"):
        list(mf.state_messages(traj))


# ---------------------------------------------------------------- (5) events


def test_events_match_the_trajectory(run: RunData, mcap_path: Path) -> None:
    events = run.trajectory.events
    assert len(events) >= 2
    msgs = _decoded(mcap_path, "/events")
    schema = _schemas(mcap_path)["/events"][2]
    assert schema == mf.EVENT_SCHEMA
    assert len(msgs) == len(events)
    for (log_time, m), e in zip(msgs, events, strict=True):
        _validate(m, schema)
        assert m == {
            "t_s": e.t_s,
            "kind": e.kind,
            "x_m": e.x_m,
            "y_m": e.y_m,
            "mu": e.mu,
            "phase": e.phase,
        }
        assert log_time == _log_ns(e.t_s)


# ---------------------------------------------------------------- (6) records


def _records(path: Path) -> tuple[dict[str, dict[str, str]], dict[str, tuple[str, bytes]]]:
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        attachments = {a.name: (a.media_type, bytes(a.data)) for a in reader.iter_attachments()}
    return meta, attachments


def test_scene_metadata_and_attachment_load_back(run: RunData, mcap_path: Path) -> None:
    meta, attachments = _records(mcap_path)
    scene_meta = meta["scene"]
    assert Scene.model_validate_json(scene_meta["scene_json"]) == run.scene
    assert scene_meta["bowlrec_version"] == bowlrec.__version__
    assert scene_meta["physics_version"] == bowlrec.PHYSICS_VERSION
    assert scene_meta["run_id"] == ""
    media_type, data = attachments["scene.json"]
    assert media_type == "application/json"
    assert Scene.model_validate_json(data) == run.scene


def test_summary_metadata(run: RunData, mcap_path: Path) -> None:
    summary = _records(mcap_path)[0]["summary"]
    s = run.trajectory.summary
    assert summary["outcome"] == s.outcome == "pins"
    assert json.loads(summary["slide_m"]) == s.slide_m
    assert json.loads(summary["hook_m"]) == s.hook_m
    assert json.loads(summary["pocket_deg"]) == s.pocket_deg
    assert json.loads(summary["n_events"]) == s.n_events
    assert summary["text"].startswith("pins")


# ---------------------------------------------------------------- scene geometry


def _entities(path: Path) -> dict[str, Any]:
    (msg,) = _decoded(path, "/scene")
    assert msg[0] == 0
    return {e.id: e for e in msg[1].entities}


def test_scene_has_lane_friction_path_and_ball(run: RunData, mcap_path: Path) -> None:
    plan, r = run.plan, run.plan.radius_m
    entities = _entities(mcap_path)
    lane = entities["lane"].cubes[0]
    assert lane.pose.position.z + lane.size.z / 2 == pytest.approx(-r)  # top = lane surface
    assert (lane.size.x, lane.size.y) == (plan.lane_length_m, plan.lane_width_m)
    cells = friction_cells(plan)
    cubes = [entities[f"friction/{i}"].cubes[0] for i in range(len(cells))]
    assert len([k for k in entities if k.startswith("friction/")]) == len(cells)
    for cell, cube in zip(cells, cubes, strict=True):
        assert cube.pose.position.z - cube.size.z / 2 > -r  # above the lane surface
        assert cube.size.x == pytest.approx(cell.x1_m - cell.x0_m)
    oil, dry = min(cells, key=lambda c: c.mu), max(cells, key=lambda c: c.mu)
    oil_cube, dry_cube = cubes[cells.index(oil)], cubes[cells.index(dry)]
    assert oil_cube.color.b > dry_cube.color.b and oil_cube.color.r < dry_cube.color.r
    path = entities["path"].lines[0]
    assert len(path.points) == len(path.colors) == run.trajectory.n_samples
    ball = entities["ball"]
    assert ball.frame_id == "ball" and ball.frame_locked
    assert ball.spheres[0].size.x == 2 * r
    assert len(entities["events"].texts) == len(run.trajectory.events)


def test_ball_markings_follow_the_body_frame(run16: RunData, mcap16: Path) -> None:
    r = run16.plan.radius_m
    marks = markings_body(run16.plan)
    assert {"pin", "cg"} <= set(marks)
    ball = _entities(mcap16)["ball"]
    pin = ball.spheres[1].pose.position  # spheres: the ball, then the markings in order
    assert np.allclose([pin.x, pin.y, pin.z], r * marks["pin"])
    (arrow,) = ball.arrows
    o = arrow.pose.orientation
    along = body_to_lane(np.array([o.w, o.x, o.y, o.z]), np.array([1.0, 0.0, 0.0]))[0]
    assert np.allclose(along, marks["cg"], atol=1e-12)  # arrow points out along the cg mark
    p = arrow.pose.position
    assert np.allclose([p.x, p.y, p.z], r * marks["cg"])


# ---------------------------------------------------------------- (7), (8) errors and atomicity


def test_summary_only_run_raises_and_leaves_no_file(tmp_path: Path) -> None:
    scene = Scene.model_validate({"name": "summary-only", "options": {"record": "summary"}})
    summary_run = _run(scene)
    target = tmp_path / "x.mcap"
    with pytest.raises(SamplesRequiredError, match="MCAP export needs samples"):
        mf.write_mcap(summary_run, target)
    with pytest.raises(SamplesRequiredError, match="record"):
        mf.write_mcap_batch([summary_run], target)
    assert list(tmp_path.iterdir()) == []


def test_failure_midway_leaves_previous_file_and_no_temp(
    run: RunData, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "run.mcap"
    target.write_bytes(b"previous")

    real = mf.state_messages

    def failing(traj: Trajectory) -> Iterator[bytes]:
        for i, msg in enumerate(real(traj)):
            if i == 50:
                raise RuntimeError("disk on fire")
            yield msg

    monkeypatch.setattr(mf, "state_messages", failing)
    with pytest.raises(RuntimeError, match="disk on fire"):
        mf.write_mcap(run, target)
    assert target.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]
    target.unlink()
    with pytest.raises(RuntimeError, match="disk on fire"):
        mf.write_mcap(run, target)
    assert list(tmp_path.iterdir()) == []


def test_same_run_gives_identical_bytes(run: RunData, mcap_path: Path, tmp_path: Path) -> None:
    again = mf.write_mcap(run, tmp_path / "again.mcap")
    assert again.read_bytes() == mcap_path.read_bytes()


# ---------------------------------------------------------------- batch files


@pytest.mark.process  # the rerun binary
def test_batch_file_holds_every_run(run: RunData, run16: RunData, tmp_path: Path) -> None:
    runs = [run, run16, run]
    keys = mf.run_keys(runs)
    assert keys == ["default", "paper-case16", "default-2"]
    path = mf.write_mcap_batch(runs, tmp_path / "batch.mcap")
    counts: Counter[str] = Counter()
    last_time = -1
    ordered = True
    with open(path, "rb") as f:
        for _, channel, message in NonSeekingReader(f, validate_crcs=True).iter_messages(
            log_time_order=False
        ):
            counts[channel.topic] += 1
            ordered &= message.log_time >= last_time
            last_time = message.log_time
    assert ordered  # runs interleaved in log-time order
    assert counts["/tf_static"] == 1
    for key, r in zip(keys, runs, strict=True):
        n = r.trajectory.n_samples
        assert counts[f"/{key}/tf"] == counts[f"/{key}/ball/state"] == n
        assert counts[f"/{key}/scene"] == 1
        assert counts[f"/{key}/events"] == len(r.trajectory.events)
        t, pos, quat = mf.read_mcap_positions(path, key)
        assert np.array_equal(t, r.trajectory.t_s)
        assert np.array_equal(pos, r.trajectory.position_m)
        assert np.array_equal(quat, r.trajectory.quaternion_wxyz)
    (static,) = _decoded(path, "/tf_static")
    lanes = {t.child_frame_id: t.translation.y for t in static[1].transforms}
    assert lanes["default/lane"] == 0.0 < lanes["paper-case16/lane"] < lanes["default-2/lane"]
    frames = {(m.parent_frame_id, m.child_frame_id) for _, m in _decoded(path, "/paper-case16/tf")}
    assert frames == {("paper-case16/lane", "paper-case16/ball")}
    meta, attachments = _records(path)
    assert json.loads(meta["batch"]["runs"]) == keys
    scene16 = meta["paper-case16/scene"]["scene_json"]
    assert Scene.model_validate_json(scene16) == run16.scene
    assert set(attachments) == {f"{k}/scene.json" for k in keys}
    done = subprocess.run(
        [_rerun_binary(), "mcap", "check", str(path)], capture_output=True, timeout=60
    )
    assert done.returncode == 0


def test_batch_needs_a_run(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="at least one run"):
        mf.write_mcap_batch([], tmp_path / "none.mcap")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.process  # a fresh interpreter's modules
def test_importing_the_sinks_package_does_not_load_foxglove_or_mcap() -> None:
    code = (
        "import sys, bowlrec, bowlrec.sinks\n"
        "assert not {'foxglove', 'mcap'} & set(sys.modules), sorted(sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
