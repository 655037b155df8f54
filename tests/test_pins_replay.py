"""A run's pins in the replay formats and on the web app's run page: rerun entities and
transforms, MCAP topics (CRC-checked, schema-valid, exact), the run page's pin-deck section
and its JSON. One flush pocket strike (about 0.3 s of pin action) shared by every test here;
the real ``rerun`` binary's checks are in the ``process`` tier."""

from __future__ import annotations

import json
import os
import subprocess
import warnings
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="pin action needs the pins extra")

import rerun_cli  # noqa: E402
from mcap.decoder import DecoderFactory  # noqa: E402
from mcap.reader import NonSeekingReader, make_reader  # noqa: E402
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory  # noqa: E402
from rerun.chunk import RrdReader  # noqa: E402

from bowlrec.api import as_scene, simulate  # noqa: E402
from bowlrec.sinks import RunData  # noqa: E402
from bowlrec.sinks import mcap_file as mf  # noqa: E402
from bowlrec.sinks.pin_replay import pin_mesh, pin_replay, pins_json  # noqa: E402
from bowlrec.sinks.rerun_recording import read_rrd_series, write_rrd  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RERUN_BIN = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")


def pin_run(name: str = "pocket-right") -> RunData:
    """examples/bowler/pocket-right.json through the pins, the lane sampled every 10 ms and
    the pins every 5 ms (at most 1 s of pin action)."""
    data = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    options = data.setdefault("options", {})
    options.update(record="rate", record_dt_s=0.01)
    options["pins"] = {"record_dt_s": 0.005, "max_time_s": 1.0}
    scene = as_scene(data)
    scene = scene.model_copy(update={"name": name})
    return RunData(scene=scene, plan=scene.resolve(), trajectory=simulate(scene))


@pytest.fixture(scope="module")
def run() -> RunData:
    return pin_run()


@pytest.fixture(scope="module")
def rrd(run: RunData, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_rrd(run, tmp_path_factory.mktemp("pins-rrd") / "pins.rrd")


@pytest.fixture(scope="module")
def mcap_path(run: RunData, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return mf.write_mcap(run, tmp_path_factory.mktemp("pins-mcap") / "pins.mcap")


# -- the poses every format shows ------------------------------------------------------------------


def test_the_run_strikes_and_its_replay_is_on_the_runs_clock(run: RunData) -> None:
    pins = run.trajectory.pins
    assert pins is not None and pins.action is not None and pins.entry is not None
    assert pins.leave == "strike"
    replay = pin_replay(run)
    assert replay is not None
    action = pins.action
    assert replay.pins == tuple(range(1, 11))
    assert np.array_equal(replay.t_s, pins.entry.t_s + action.t_s)
    radius = run.plan.radius_m
    # the engine's surface is z = 0, the sinks' z = -R; parked samples hold the last pose
    parked = action.pin_position_m[..., 2] < -100.0
    assert np.array_equal(replay.in_pit, parked)
    kept = ~parked
    assert np.allclose(
        replay.pin_position_m[kept], action.pin_position_m[kept] - [0.0, 0.0, radius], atol=0
    )
    assert np.all(replay.pin_position_m[..., 2] > -radius - 1.0)  # none 1 km down
    # the first samples: every pin upright on its spot, base on the lane's surface
    assert np.allclose(replay.pin_position_m[0, :, 2], -radius, atol=1e-3)
    # the ball's track: the kernel before the hand-off, then the engine
    t, pos, quat = replay.ball_track(run)
    assert np.all(np.diff(t) >= 0.0)  # (the kernel samples an event's time twice)
    assert t[replay.lane_cut - 1] < t[replay.lane_cut] == replay.handoff_t_s
    assert t.size == replay.lane_cut + replay.n_samples
    assert np.all(run.trajectory.t_s[: replay.lane_cut] < replay.handoff_t_s)
    assert np.allclose(pos[replay.lane_cut, 2], 0.0, atol=1e-3)  # centre plane, z = 0
    assert np.allclose(np.linalg.norm(quat, axis=1), 1.0)


def test_the_pin_mesh_is_the_revolved_profile() -> None:
    from bowlrec.pins.profile import HEIGHT_M, mass_properties, radius_m

    verts, tris, normals, colors = pin_mesh()
    assert verts.shape == normals.shape == colors.shape
    assert tris.min() == 0 and tris.max() == len(verts) - 1
    assert np.isclose(verts[:, 2].max(), HEIGHT_M) and verts[:, 2].min() == 0.0
    r = np.hypot(verts[:-1, 0], verts[:-1, 1])  # the last: the base's centre
    assert np.allclose(r, radius_m(verts[:-1, 2]), atol=1e-8)
    # closed and outward: the divergence theorem gives the solid's volume (inscribed
    # 24-gons hold 1.1 % less than the circles)
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
    assert volume == pytest.approx(mass_properties().volume_m3, rel=0.02)
    assert np.any(colors[:, 1] < 0.5)  # the red stripes at the neck


# -- rerun -------------------------------------------------------------------------------------


def _chunks(path: Path) -> list[Any]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return list(RrdReader(path).stream())


def test_rerun_has_the_pins_the_deck_and_the_leave(run: RunData, rrd: Path) -> None:
    chunks = _chunks(rrd)
    entities = {c.entity_path for c in chunks}
    for n in range(1, 11):
        assert f"/world/pins/{n}" in entities
        assert f"/world/pins/{n}/label" in entities
    assert {"/world/deck", "/world/deck/spots", "/world/deck/ball_path", "/pins"} <= entities
    static = {
        name
        for c in chunks
        if c.entity_path == "/world/pins/1" and c.is_static
        for name in c.to_record_batch().schema.names
    }
    assert {"Mesh3D:vertex_positions", "Mesh3D:triangle_indices"} <= static
    # the leave: a TextLog row on /events when pin action ended, and the /pins document
    texts = [
        str(v)
        for c in chunks
        if c.entity_path == "/events"
        for v in c.to_record_batch().column("TextLog:text").to_pylist()
    ]
    assert any("strike" in t for t in texts)
    doc = [
        c.to_record_batch().column("TextDocument:text").to_pylist()
        for c in chunks
        if c.entity_path == "/pins"
    ]
    assert "strike" in str(doc)
    # the footer is there: the store loads (what `rerun rrd verify` checks first)
    assert "/world/pins/10" in str(RrdReader(rrd).store().summary())


def test_rerun_pin_transforms_are_samples_times_pins(run: RunData, rrd: Path) -> None:
    replay = pin_replay(run)
    assert replay is not None
    total = 0
    for k, n in enumerate(replay.pins):
        t, pos = read_rrd_series(rrd, f"/world/pins/{n}", "Transform3D:translation")
        _, quat = read_rrd_series(rrd, f"/world/pins/{n}", "Transform3D:quaternion")
        assert np.allclose(t, replay.t_s, atol=1e-9)
        assert np.allclose(pos, replay.pin_position_m[:, k], atol=1e-5)
        assert np.allclose(quat, replay.pin_quaternion_wxyz[:, k, [1, 2, 3, 0]], atol=1e-6)
        total += t.size
    assert total == replay.n_samples * len(replay.pins)
    # the ball continues through the deck on the same timeline
    t, pos = read_rrd_series(rrd, "/world/ball", "Transform3D:translation")
    assert t.size == replay.lane_cut + replay.n_samples
    assert t[-1] == pytest.approx(replay.t_s[-1], abs=1e-9)
    assert np.allclose(pos[-replay.n_samples :], replay.ball_position_m, atol=1e-5)


def test_rerun_without_pins_has_no_pin_entities(run: RunData, tmp_path: Path) -> None:
    plain = replace(run, trajectory=replace(run.trajectory, pins=None))
    path = write_rrd(plain, tmp_path / "plain.rrd")
    entities = {c.entity_path for c in _chunks(path)}
    assert not any(e.startswith(("/world/pins", "/world/deck", "/pins")) for e in entities)
    t, _ = read_rrd_series(path, "/world/ball", "Transform3D:translation")
    assert t.size == run.trajectory.n_samples


@pytest.mark.process  # the rerun binary
def test_the_rrd_passes_rerun_verify(rrd: Path) -> None:
    done = subprocess.run(
        [RERUN_BIN, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr


# -- MCAP --------------------------------------------------------------------------------------


class _JsonDecoderFactory(DecoderFactory):
    def decoder_for(self, message_encoding: str, schema: Any) -> Any:
        return json.loads if message_encoding == "json" else None


def _decoded(path: Path, topic: str) -> list[tuple[int, Any]]:
    factories = [ProtobufDecoderFactory(), _JsonDecoderFactory()]
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=factories)
        return [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(topics=[topic])]


def _validate(value: Any, schema: dict[str, Any], where: str = "$") -> None:
    """The JSON-schema subset of the sink's schemas (jsonschema is not a dependency)."""
    kinds = schema.get("type")
    kinds = kinds if isinstance(kinds, list) else [kinds]
    checks = {
        "object": lambda v: isinstance(v, dict),
        "array": lambda v: isinstance(v, list),
        "number": lambda v: isinstance(v, int | float) and not isinstance(v, bool),
        "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
        "string": lambda v: isinstance(v, str),
        "boolean": lambda v: isinstance(v, bool),
        "null": lambda v: v is None,
    }
    assert any(checks[k](value) for k in kinds), f"{where}: {value!r} is not {kinds}"
    if isinstance(value, dict):
        props = schema["properties"]
        assert set(schema["required"]) <= set(value), f"{where}: missing fields"
        if schema.get("additionalProperties") is False:
            assert set(value) <= set(props), f"{where}: extra {set(value) - set(props)}"
        for key, sub in props.items():
            _validate(value[key], sub, f"{where}.{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _validate(item, schema["items"], f"{where}[{i}]")
    if "enum" in schema:
        assert value in schema["enum"], where
    if "minimum" in schema:
        assert schema["minimum"] <= value <= schema["maximum"], where


def test_mcap_messages_per_topic(run: RunData, mcap_path: Path) -> None:
    replay = pin_replay(run)
    assert replay is not None
    with open(mcap_path, "rb") as f:  # every chunk's and the data section's CRC
        counts = Counter(
            ch.topic
            for _, ch, _ in NonSeekingReader(f, validate_crcs=True).iter_messages(
                log_time_order=False
            )
        )
    assert counts == {
        "/scene": 1,
        "/tf": replay.lane_cut + replay.n_samples,
        "/ball/state": run.trajectory.n_samples,
        "/events": len(run.trajectory.events),
        "/pins/scene": 2,
        "/pins/tf": replay.n_samples,
        "/pins/result": 1,
    }


def test_mcap_pin_transforms_are_exact(run: RunData, mcap_path: Path) -> None:
    replay = pin_replay(run)
    assert replay is not None
    msgs = _decoded(mcap_path, "/pins/tf")
    times = np.array([t for t, _ in msgs])
    assert np.array_equal(times, np.rint(replay.t_s * 1e9).astype(np.int64))
    pos = np.array(
        [
            [[t.translation.x, t.translation.y, t.translation.z] for t in m.transforms]
            for _, m in msgs
        ]
    )
    quat = np.array(
        [
            [[t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z] for t in m.transforms]
            for _, m in msgs
        ]
    )
    assert pos.shape == (replay.n_samples, 10, 3)
    assert np.array_equal(pos, replay.pin_position_m)  # float64, bit for bit
    assert np.array_equal(quat, replay.pin_quaternion_wxyz)
    first = msgs[0][1].transforms
    assert [t.child_frame_id for t in first] == [f"pin{n}" for n in range(1, 11)]
    assert {t.parent_frame_id for t in first} == {"lane"}
    # the ball's /tf ends with the engine's samples
    tf = _decoded(mcap_path, "/tf")
    ball = np.array([[m.translation.x, m.translation.y, m.translation.z] for _, m in tf])
    assert np.array_equal(ball[-replay.n_samples :], replay.ball_position_m)


def test_mcap_pin_scene_and_result(run: RunData, mcap_path: Path) -> None:
    replay = pin_replay(run)
    assert replay is not None
    scenes = _decoded(mcap_path, "/pins/scene")
    (t0, first), (t1, last) = scenes
    assert t0 == round(replay.handoff_t_s * 1e9)
    ids = [e.id for e in first.entities]
    assert ids == ["pins/deck", *(f"pins/{n}" for n in range(1, 11))]
    verts, tris, _, _ = pin_mesh()
    for e in first.entities[1:]:
        assert e.frame_locked and e.frame_id == f"pin{e.id.split('/')[1]}"
        (tri,) = e.triangles
        assert len(tri.points) == len(verts) and len(tri.indices) == tris.size
        assert e.texts[0].text == e.id.split("/")[1]
    deck = first.entities[0]
    assert len(deck.cylinders) == 10 and len(deck.lines) == 2
    assert [e.id for e in last.entities] == ["pins/leave"]
    assert "strike" in last.entities[0].texts[0].text
    # the result: once, when pin action ended, valid against its schema
    with open(mcap_path, "rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None
    (channel,) = [c for c in summary.channels.values() if c.topic == "/pins/result"]
    schema = summary.schemas[channel.schema_id]
    assert (schema.name, schema.encoding, channel.message_encoding) == (
        "bowlrec.PinResult",
        "jsonschema",
        "json",
    )
    assert json.loads(schema.data) == mf.PIN_RESULT_SCHEMA
    ((t, result),) = _decoded(mcap_path, "/pins/result")
    _validate(result, mf.PIN_RESULT_SCHEMA)
    pins = run.trajectory.pins
    assert pins is not None
    assert t == t1 >= round(replay.t_s[-1] * 1e9)
    assert result["leave"] == "strike" and result["pinfall"] == 10 and result["standing"] == []
    assert tuple(result["touched"]) == pins.touched
    assert result["exit_board"] == pins.exit_board
    # the Foxglove well-known schemas
    names = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert names["/pins/tf"] == "foxglove.FrameTransforms"
    assert names["/pins/scene"] == "foxglove.SceneUpdate"
    # and the metadata record
    with open(mcap_path, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert meta["pins"]["leave"] == "strike"
    assert json.loads(meta["pins"]["pinfall"]) == 10


def test_mcap_batch_prefixes_the_pin_topics(run: RunData, tmp_path: Path) -> None:
    other = replace(run, scene=run.scene.model_copy(update={"name": "again"}))
    path = mf.write_mcap_batch([run, other], tmp_path / "batch.mcap")
    with open(path, "rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None
    topics = {c.topic for c in summary.channels.values()}
    for key in mf.run_keys([run, other]):
        assert {f"/{key}/pins/tf", f"/{key}/pins/scene", f"/{key}/pins/result"} <= topics
    msgs = _decoded(path, f"/{mf.run_keys([run, other])[1]}/pins/tf")
    assert msgs[0][1].transforms[0].child_frame_id == "again/pin1"


@pytest.mark.process  # the rerun binary
def test_the_mcap_passes_rerun_mcap_check(mcap_path: Path) -> None:
    done = subprocess.run(
        [RERUN_BIN, "mcap", "check", str(mcap_path)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr


# -- the web app's run page ---------------------------------------------------------------------


def test_pins_json_for_the_deck_view(run: RunData) -> None:
    data = pins_json(run)
    assert data is not None
    json.dumps(data, allow_nan=False)
    replay = pin_replay(run)
    assert replay is not None
    n = replay.n_samples
    assert data["leave"] == "strike" and data["pinfall"] == 10
    assert len(data["t_s"]) == n and data["t_s"][0] == 0.0
    assert [p["pin"] for p in data["pins"]] == list(range(1, 11))
    for p in data["pins"]:
        assert len(p["base"]) == len(p["head"]) == len(p["in_pit"]) == n
        # set upright: the head straight above the base
        assert np.allclose(p["base"][0], p["head"][0], atol=1e-3)
        assert np.allclose(p["base"][0], data["deck"]["spots"][str(p["pin"])], atol=1e-3)
    assert len(data["ball"]) == n
    assert data["deck"]["x1_m"] > data["deck"]["x0_m"]
    assert data["exit_y_m"] is not None
    assert pins_json(replace(run, trajectory=replace(run.trajectory, pins=None))) is None


@pytest.fixture(scope="module")
def app(run: RunData, tmp_path_factory: pytest.TempPathFactory, module_app_server: Any) -> Any:
    """An archive holding the pin run and a run without pins, served in process. An archive
    that does not keep pins (format before 2.2) gets the pin run in the server's replay
    cache, as it would have loaded it."""
    pytest.importorskip("fastapi")
    pytest.importorskip("jinja2")
    from bowlrec.api import simulate_into
    from bowlrec.archive import Archive

    root = tmp_path_factory.mktemp("pins-web") / "archive"
    archive = Archive(root)
    rid = simulate_into(archive, run.scene).run_id
    plain = run.scene.model_copy(
        update={"name": "no-pins", "options": run.scene.options.model_copy(update={"pins": False})}
    )
    plain_rid = simulate_into(archive, plain).run_id
    archive.close()
    server = module_app_server(root)
    seed_pins(server.app.state.bowlrec.replays, rid, run)
    return server, rid, plain_rid


def seed_pins(replays: Any, rid: str, run: RunData) -> None:
    """Put ``run``'s pins into the replay cache's copy of ``rid`` when the archive lost them."""
    stored = replays.run(rid)
    if stored.trajectory.pins is None:
        pins = run.trajectory.pins
        replays._runs[rid] = replace(stored, trajectory=replace(stored.trajectory, pins=pins))


def test_the_run_page_has_a_pin_deck_and_its_json(app: Any) -> None:
    server, rid, plain_rid = app
    with server.client() as client:
        page = client.get(f"/ui/runs/{rid}")
        assert page.status_code == 200
        assert f'id="pin-deck" data-run="{rid}"' in page.text
        assert 'id="deck-svg"' in page.text and 'id="deck-time"' in page.text
        answer = client.get(f"/runs/{rid}/pins")
        assert answer.status_code == 200
        data = answer.json()
        assert data["leave"] == "strike" and len(data["pins"]) == 10
        assert data["touched"][:1] == [1]
        assert client.get(f"/runs/{rid[:10]}/pins").json() == data  # a prefix resolves
        # a run without pin action: no section, and null from the API
        page = client.get(f"/ui/runs/{plain_rid}")
        assert page.status_code == 200 and 'id="pin-deck"' not in page.text
        assert client.get(f"/runs/{plain_rid}/pins").json() is None
        assert client.get("/runs/ffffffffffff/pins").status_code == 404
