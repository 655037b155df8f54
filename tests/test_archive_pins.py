"""A run's pins in the archive (segment format 2.2): stored as per-run record groups and read
back equal, checked by the run's digest, carried by compaction, indexed (``pinfall``,
``leave``) and listed and filtered by ``runs list``; runs without pins stored as before; the
committed 2.2 fixture and the chain of formats from 1.0.

Most tests attach a made-up :class:`PinOutcome` to a cheap trajectory (no MuJoCo); the real
engine runs twice (``max_time_s`` 1 s), skipped without the pins extra.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from bowlrec.archive import Archive, SegmentFile
from bowlrec.errors import RunDamagedError
from bowlrec.paper import paper_scene
from bowlrec.pins.engine import BallEntry, PinAction
from bowlrec.pins.outcome import PinOutcome, standing_offsets_m
from bowlrec.pins.records import PIN_GROUPS, pin_groups, pin_outcome_of
from bowlrec.sinks import RunData
from bowlrec.spec import Scene

HERE = Path(__file__).parent
FIXTURES = HERE / "fixtures"
try:  # imported when the module is collected: its import probes GLFW in a subprocess
    import mujoco  # noqa: F401

    HAS_MUJOCO = True
except ImportError:
    HAS_MUJOCO = False
needs_mujoco = pytest.mark.skipif(not HAS_MUJOCO, reason="needs the pins extra (MuJoCo)")


def _scene(record: str = "rate") -> Scene:
    base = paper_scene(16).model_dump(mode="json")
    base["options"] = {"record": record, "record_dt_s": 0.05}
    return Scene.model_validate(base)


@pytest.fixture(scope="module")
def plain_run() -> RunData:
    import bowlrec

    scene = _scene()
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))


def _outcome(
    set_pins: tuple[int, ...] = tuple(range(1, 11)),
    standing: tuple[int, ...] = (10,),
    leave: str = "10",
    touched: tuple[int, ...] = (1, 3, 5, 9),
    n: int = 7,
    seed: int = 0,
    extras: dict[str, float] | None = None,
    reached: bool = True,
) -> PinOutcome:
    """A made-up pin outcome (random motion, every value distinct)."""
    rng = np.random.default_rng(seed)
    k = len(set_pins)
    action = entry = None
    if reached:
        action = PinAction(
            set_pins=set_pins,
            standing=standing,
            touched=touched,
            t_s=np.arange(n) * 0.005,
            pin_position_m=rng.normal(size=(n, k, 3)),
            pin_quaternion_wxyz=rng.normal(size=(n, k, 4)),
            ball_position_m=rng.normal(size=(n, 3)),
            ball_quaternion_wxyz=rng.normal(size=(n, 4)),
            energy_J=rng.random(n),
            exit_y_m=None if seed % 2 else 0.51234,
            time_s=float(n) * 0.005 + 1e-17,
            at_rest=bool(seed % 2),
            n_steps=12345 + seed,
            wall_time_s=0.25,
            engine="mujoco 3.17.0",
            extras=extras or {},
        )
        entry = BallEntry(
            t_s=2.47,
            position_m=(18.1, 0.44),
            velocity_mps=(6.48, 0.50),
            omega_radps=(-4.6, 59.4, 7.3),
            quaternion_wxyz=(-0.29, -0.43, -0.81, 0.28),
            mass_kg=6.8,
            radius_m=0.109,
            inertia_per_mass_m2=(0.004, 0.0042, 0.0042),
            r_delta_body_m=(0.0, 1e-4, 0.0),
            deck_friction=0.19,
        )
    return PinOutcome(
        set_pins=set_pins,
        standing=standing,
        leave=leave,
        hand="right",
        touched=touched if reached else (),
        exit_board=None if seed % 2 or not reached else 17.2376,
        deflection_boards=None if seed % 2 or not reached else 2.74,
        action=action,
        entry=entry,
    )


def _with_pins(
    run: RunData, pins: PinOutcome | None, rid: str, record: str | None = None
) -> RunData:
    scene = run.scene
    if record is not None:
        scene = scene.model_copy(
            update={"options": scene.options.model_copy(update={"record": record})}
        )
    return RunData(scene, run.plan, dataclasses.replace(run.trajectory, pins=pins), rid)


def _rid(i: int) -> str:
    return f"{i:020x}"


def _assert_same_pins(a: PinOutcome | None, b: PinOutcome | None) -> None:
    """Every value and array equal, bit for bit (dataclass == cannot compare arrays)."""
    assert (a is None) == (b is None)
    if a is None or b is None:
        return
    for f in dataclasses.fields(PinOutcome):
        if f.name not in ("action", "entry"):
            assert getattr(a, f.name) == getattr(b, f.name), f.name
    assert a.entry == b.entry
    assert (a.action is None) == (b.action is None)
    if a.action is None or b.action is None:
        return
    for f in dataclasses.fields(PinAction):
        x, y = getattr(a.action, f.name), getattr(b.action, f.name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, f.name
            assert np.array_equal(x, y), f.name
        else:
            assert type(x) is type(y) and x == y, f.name


# -- stored and read back ------------------------------------------------------------------------


def test_pins_round_trip_every_value_and_array(tmp_path: Path, plain_run: RunData) -> None:
    """A full rack and a partial rack (a spare ball: three pins set) with the engine's extra
    values, and a ball that never reached the pins: Archive.load gives the same PinOutcome;
    the segment declares 2.2 and the run's provenance names the pin engine."""
    archive = Archive(tmp_path / "a")
    outcomes = [
        _outcome(extras={"restitution_achieved": 0.812, "x": -1.5}),
        _outcome((6, 9, 10), (10,), "10", (6, 9), n=3, seed=1),
        _outcome((1, 2, 4, 7), (1, 2, 4, 7), "1-2-4-7", reached=False),
    ]
    for i, pins in enumerate(outcomes):
        archive.add(_with_pins(plain_run, pins, _rid(i)), wall_time_s=0.0)
    for i, pins in enumerate(outcomes):
        stored = archive.load(_rid(i))
        _assert_same_pins(stored.trajectory.pins, pins)
        assert stored.trajectory.pins == pins  # dataclass equality, the arrays by value
        assert stored.attrs["format_version"] == "3.0"  # the runs have samples
        engine = stored.attrs.get("pin_engine_version")
        assert engine == (None if pins.action is None else "mujoco 3.17.0")
    with SegmentFile(archive.locate(_rid(1))[2]) as seg:  # type: ignore[index]
        f = seg._f
        assert f["pins/pin_position_m"].shape == (3, 10, 3)  # pin p in column p - 1
        assert np.isnan(f["pins/pin_position_m"][:, :5]).all()
        assert list(f["pin_outcome/set_pins"][0]) == [6, 9, 10, 0, 0, 0, 0, 0, 0, 0]
        units = {f"{g}/{k}": f[g][k].attrs["units"] for g in f if g.startswith("pin") for k in f[g]}
    assert units["pins/pin_position_m"] == "m" and units["pin_outcome/exit_board"] == "board"
    assert units["pin_entry/velocity_mps"] == "m/s" and units["pins/energy_J"] == "J"
    assert pin_outcome_of({}) is None


def test_runs_with_and_without_pins_share_a_segment_and_compaction_carries_them(
    tmp_path: Path, plain_run: RunData
) -> None:
    """Racks of any size, leaves of any length and runs without pins in one segment; merged by
    compaction into one 2.3 segment, every run reads back equal and checked."""
    archive = Archive(tmp_path / "a")
    outcomes: list[PinOutcome | None] = [
        _outcome(),
        None,
        _outcome((7, 10), (7, 10), "7-10", (), n=4, seed=3),
        _outcome(standing=(), leave="strike", n=9, seed=4),
    ]
    builder = archive.builder()
    for i, pins in enumerate(outcomes[:3]):
        builder.append(archive.record(_with_pins(plain_run, pins, _rid(i)), wall_time_s=0.0))
    archive.register([archive.seal(builder)])
    archive.add(_with_pins(plain_run, outcomes[3], _rid(3)), wall_time_s=0.0)
    archive.add(_with_pins(plain_run, None, _rid(4)), wall_time_s=0.0)
    assert archive.compact()["segments_written"] == 1
    for i, pins in enumerate([*outcomes, None]):
        stored = archive.load(_rid(i))
        _assert_same_pins(stored.trajectory.pins, pins)
        assert stored.trajectory.pins == pins  # dataclass equality, the arrays by value
        assert stored.attrs["format_version"] == "3.0"
    assert archive.repair()["damaged_runs"] == []


def test_a_summary_only_run_keeps_where_the_pins_came_to_rest(
    tmp_path: Path, plain_run: RunData
) -> None:
    """``record: summary`` keeps the pins' outcome, the engine's result, the ball's entry and
    the last sample (the pins at rest: the next ball's moved pins), not the whole motion."""
    archive = Archive(tmp_path / "a")
    pins = _outcome(standing=(4, 7, 10), leave="4-7-10", n=11, seed=5)
    archive.add(_with_pins(plain_run, pins, _rid(1), record="summary"), wall_time_s=0.0)
    back = archive.load(_rid(1)).trajectory.pins
    assert back is not None and back.action is not None and pins.action is not None
    assert back.action.t_s.tolist() == [pins.action.t_s[-1]]
    np.testing.assert_array_equal(back.action.pin_position_m, pins.action.pin_position_m[-1:])
    rest = dataclasses.replace(
        pins,
        action=dataclasses.replace(
            pins.action,
            **{
                k: getattr(pins.action, k)[-1:]
                for k in ("t_s", "pin_position_m", "pin_quaternion_wxyz")
                + ("ball_position_m", "ball_quaternion_wxyz", "energy_J")
            },
        ),
    )
    _assert_same_pins(back, rest)
    assert standing_offsets_m(back, 18.288, 1.0541) == standing_offsets_m(pins, 18.288, 1.0541)


def test_a_run_without_pins_is_stored_as_before_but_for_the_later_changes(tmp_path: Path) -> None:
    """The committed 2.0 fixture's runs, written again by this code (format 3.0: they have
    samples): every dataset of the fixture that 3.0 keeps is equal, units included; the ones
    2.3 stores otherwise (the scenes, the per-run digests, event kinds and phases as text) read
    back equal; the ones 3.0 derives on read stay stored, as these runs' state does not give
    them back bit for bit; with a session's record groups, 3.0 too."""
    archive = Archive(tmp_path / "a")
    original = next((FIXTURES / "archive-v2" / "segments").glob("*.h5"))
    with SegmentFile(original) as seg:
        records = [r.to_record() for r in seg.read_all()]
    assert all(not r.records for r in records)
    builder = archive.builder()
    for r in records:
        builder.append(r)
    info = archive.seal(builder)

    def datasets(path: Path) -> dict[str, Any]:
        out: dict[str, Any] = {}
        with h5py.File(path) as f:
            f.visititems(
                lambda name, obj: (
                    out.__setitem__(name, (obj[()], dict(obj.attrs)))
                    if isinstance(obj, h5py.Dataset)
                    else None
                )
            )
            out["_version"] = f.attrs["format_version"]
        return out

    new, old = datasets(info.path), datasets(original)
    assert (new.pop("_version"), old.pop("_version")) == ("3.0", "2.0")
    stored_otherwise = {"runs/digest", "runs/scene_json", "runs/scene_json_offsets"}
    stored_otherwise |= {"events/kind", "events/phase"}
    # the forces, slip, energy and alpha stay stored: a 2.0 run's friction direction is not the
    # kernel's, so its state does not give them back bit for bit (derived on read otherwise)
    assert old.keys() - new.keys() == stored_otherwise - {"events/kind", "events/phase"}
    assert new.keys() - old.keys() == {
        "scene/base_json",
        "scene/override_paths",
        "scene/override_values",
        "scene/override_json",
        "scene/override_offsets",
        "digest/blocks",
        "trajectory/friction_dir",
    }
    for name in old.keys() - stored_otherwise:
        (a, a_attrs), (b, b_attrs) = new[name], old[name]
        assert a.dtype == b.dtype and np.array_equal(a, b), name
        assert a_attrs["units"] == b_attrs["units"], name
    with SegmentFile(info.path) as seg:
        again = [r.to_record() for r in seg.read_all()]
    for a_rec, b_rec in zip(again, records, strict=True):
        assert a_rec.scene_json == b_rec.scene_json and a_rec.events == b_rec.events
        assert a_rec.trajectory.keys() == b_rec.trajectory.keys()
        for key, arr in a_rec.trajectory.items():
            assert arr.tobytes() == b_rec.trajectory[key].tobytes(), key
    with_session = dataclasses.replace(
        records[0], records={"session": {"state_json": np.frombuffer(b"{}", dtype=np.uint8)}}
    )
    builder = archive.builder()
    builder.append(with_session)
    with SegmentFile(archive.seal(builder).path) as seg:
        assert seg.provenance["format_version"] == "3.0"


@pytest.mark.parametrize("group", [g for g in PIN_GROUPS])
def test_the_digest_covers_every_pin_group(tmp_path: Path, plain_run: RunData, group: str) -> None:
    """A changed byte in any pin group damages that run, named; its neighbours read."""
    archive = Archive(tmp_path / "a")
    builder = archive.builder()
    for i, pins in enumerate([_outcome(extras={"e": 1.0}), _outcome(seed=2), None]):
        builder.append(archive.record(_with_pins(plain_run, pins, _rid(i)), wall_time_s=0.0))
    info = archive.seal(builder)
    archive.register([info])
    archive.close()
    with h5py.File(info.path, "r+") as f:
        name = sorted(k for k in f[group] if k != "offsets")[-1]
        data = f[group][name][()]
        raw = data.view(np.uint8).reshape(-1)
        raw[0] ^= 0x01  # the first run's first row: one bit
        f[group][name][...] = data
    with pytest.raises(RunDamagedError, match=f"run {_rid(0)} in segment {info.segment_id}"):
        archive.load(_rid(0))
    for i in (1, 2):
        archive.load(_rid(i))
    with SegmentFile(info.path) as seg:
        healthy, damaged = seg.verify()
    assert healthy == [1, 2] and list(damaged) == [0]


def test_pin_groups_refuse_what_they_cannot_store() -> None:
    with pytest.raises(ValueError, match="pin numbers"):
        pin_groups(_outcome(standing=(11,), reached=False))
    pins = _outcome()
    with pytest.raises(ValueError, match="differ"):
        pin_groups(dataclasses.replace(pins, standing=()))


# -- the index -----------------------------------------------------------------------------------


def _indexed_archive(tmp_path: Path, plain_run: RunData) -> Archive:
    archive = Archive(tmp_path / "a")
    outcomes: list[PinOutcome | None] = [
        _outcome(standing=(), leave="strike", seed=0),
        _outcome(standing=(10,), leave="10", seed=1),
        _outcome(standing=(7, 10), leave="7-10", seed=2),
        None,
        _outcome(standing=(), leave="strike", seed=3),
    ]
    for i, pins in enumerate(outcomes):
        archive.add(_with_pins(plain_run, pins, _rid(i)), wall_time_s=0.0)
    return archive


def _ids(rows: list[dict[str, Any]]) -> list[int]:
    return sorted(int(r["run_id"], 16) for r in rows)


def test_index_lists_filters_and_rebuilds_pinfall_and_leave(
    tmp_path: Path, plain_run: RunData
) -> None:
    archive = _indexed_archive(tmp_path, plain_run)
    rows = {int(r["run_id"], 16): r for r in archive.list_runs()}
    assert [(rows[i]["pinfall"], rows[i]["leave"]) for i in range(5)] == [
        (10, "strike"),
        (9, "10"),
        (8, "7-10"),
        (None, None),
        (10, "strike"),
    ]
    assert _ids(archive.list_runs(strikes=True)) == [0, 4]
    assert _ids(archive.list_runs(leave="10")) == [1]
    assert _ids(archive.list_runs(pinfall=8)) == [2]
    assert _ids(archive.list_runs(where=["pinfall<=9"])) == [1, 2]
    assert _ids(archive.list_runs(where=["leave!=strike"])) == [1, 2]
    assert archive.count_runs(strikes=True) == 2
    assert _ids(archive.list_runs(order_by="-pinfall", limit=2)) == [0, 4]
    before = archive.list_runs()
    archive.reindex()
    assert archive.list_runs() == before
    con = sqlite3.connect(tmp_path / "a" / "index.sqlite")
    plan = " ".join(
        str(r) for r in con.execute("EXPLAIN QUERY PLAN SELECT * FROM runs WHERE leave = 'x'")
    )
    assert "runs_leave" in plan  # the partial index serves the leave filter
    con.close()


def test_an_index_of_format_2_is_read_and_upgraded_in_place(
    tmp_path: Path, plain_run: RunData
) -> None:
    """An index written before pins (format 2: no pinfall, leave): a reader lists from an index
    built in memory, the next writer adds the columns in place and fills them from the
    segments (no rebuild)."""
    archive = _indexed_archive(tmp_path, plain_run)
    expected = archive.list_runs()
    archive.close()
    path = tmp_path / "a" / "index.sqlite"
    con = sqlite3.connect(path, isolation_level=None)
    con.execute("DROP INDEX runs_leave")
    con.execute("DROP INDEX runs_pinfall")
    con.execute("ALTER TABLE runs DROP COLUMN pinfall")
    con.execute("ALTER TABLE runs DROP COLUMN leave")
    con.execute("UPDATE meta SET value = '2' WHERE key = 'index_format'")
    seq_before = [r[0] for r in con.execute("SELECT seq FROM runs ORDER BY seq")]
    con.close()
    reader = Archive(tmp_path / "a", create=False)
    assert reader.list_runs() == expected  # from the data files, in memory
    reader.close()
    writer = Archive(tmp_path / "a")
    writer.add(_with_pins(plain_run, _outcome(leave="9", standing=(9,)), _rid(9)), wall_time_s=0)
    con = sqlite3.connect(path)
    assert con.execute("SELECT value FROM meta WHERE key = 'index_format'").fetchone() == ("3",)
    assert [r[0] for r in con.execute("SELECT seq FROM runs ORDER BY seq")][:5] == seq_before
    con.close()
    assert [r for r in writer.list_runs() if r["run_id"] != _rid(9)] == expected
    assert _ids(writer.list_runs(leave="9")) == [9]


def test_runs_list_shows_and_filters_the_pins(tmp_path: Path, plain_run: RunData) -> None:
    from bowlrec.cli import app

    runner = CliRunner()
    archive = _indexed_archive(tmp_path, plain_run)
    archive.close()
    a = str(tmp_path / "a")

    def run(*args: str) -> str:
        result = runner.invoke(app, ["runs", "list", "-a", a, *args])
        assert result.exit_code == 0, result.output
        return result.stdout

    table = run()
    assert "leave" in table and "pinfall" in table and "7-10" in table
    assert run("--strikes", "--ids").split() == [_rid(4), _rid(0)]
    assert run("--leave", "7-10", "--ids").split() == [_rid(2)]
    assert run("--pinfall", "9", "--ids").split() == [_rid(1)]
    assert run("-w", "pinfall<10", "--ids").split() == [_rid(2), _rid(1)]
    rows = json.loads(run("--json", "--leave", "10"))
    assert [(r["pinfall"], r["leave"]) for r in rows] == [(9, "10")]
    only_plain = json.loads(run("--json", "-w", f"run_id={_rid(3)}"))
    assert only_plain[0]["pinfall"] is None
    assert "pinfall" not in run("-w", f"run_id={_rid(3)}")  # no run with pins: as before
    shown = runner.invoke(app, ["runs", "show", _rid(2), "-a", a, "--json"])
    assert json.loads(shown.stdout)["pins"]["leave"] == "7-10"


# -- the real engine, the fixture and the chain of formats ---------------------------------------


@needs_mujoco
def test_a_real_pin_action_round_trips(tmp_path: Path) -> None:
    """The README's pocket shot through the engine (1 s at most), simulated into the archive:
    loaded back equal; the index and the provenance say what the pins did and with what."""
    from bowlrec.api import as_scene, simulate_into
    from bowlrec.pins.engine import engine_version

    doc = json.loads((HERE.parent / "examples" / "bowler" / "pocket-right.json").read_text())
    doc["options"] = {"record": "rate", "record_dt_s": 0.05, "pins": {"max_time_s": 1.0}}
    archive = Archive(tmp_path / "a")
    res = simulate_into(archive, as_scene(doc))
    assert res.trajectory is not None and res.trajectory.pins is not None
    stored = archive.load(res.run_id)
    _assert_same_pins(stored.trajectory.pins, res.trajectory.pins)
    assert stored.attrs["pin_engine_version"] == engine_version()
    row = archive.row(res.run_id)
    assert (row["pinfall"], row["leave"]) == (
        res.trajectory.pins.pinfall,
        res.trajectory.pins.leave,
    )
    again = simulate_into(archive, as_scene(doc))  # stored already: read back, not simulated
    assert not again.added and again.trajectory is not None
    _assert_same_pins(again.trajectory.pins, res.trajectory.pins)


def test_committed_v2_2_fixture_archive_reads(tmp_path: Path) -> None:
    """tests/fixtures/archive-v2.2 (tests/fixtures/make_fixture_v22.py) holds one segment of
    three runs: the pocket shot with pin action recorded, summary-only, and without pins.
    If this fails, the on-disk format changed: see test_committed_v2_fixture_archive_still_reads
    in test_archive.py."""
    expected = json.loads((FIXTURES / "archive-v2.2.json").read_text())
    copy = shutil.copytree(FIXTURES / "archive-v2.2", tmp_path / "archive")
    archive = Archive(copy, create=False)
    assert archive.repair()["damaged_runs"] == []
    for name, want in expected.items():
        stored = archive.load(want["run_id"])
        assert stored.scene.name == name
        assert stored.attrs["format_version"] == "2.2"
        pins = stored.trajectory.pins
        assert (None if pins is None else pins.to_dict()) == want["pins"]
        if pins is not None:
            assert pins.action is not None and pins.entry is not None
            assert pins.action.t_s.shape == (want["pin_samples"],)
            assert pins.action.pin_position_m.shape == (want["pin_samples"], 10, 3)
            assert stored.attrs["pin_engine_version"].startswith("mujoco ")
        row = archive.row(want["run_id"])
        assert row["pinfall"] == (None if pins is None else pins.pinfall)
    assert _names(archive.list_runs(strikes=True)) == ["fixture-pins", "fixture-pins-summary"]


def test_committed_v2_3_fixture_archive_reads(tmp_path: Path) -> None:
    """tests/fixtures/archive-v2.3 (tests/fixtures/make_fixture_v23.py): a batch sweep's
    segment (the swept values as override columns, one digest block) and a builder's segment
    (JSON overrides, a recorded run: a digest per run) read back as written: the scene text,
    summary, events and samples; a migration rewrites the segment with samples as 3.0 and
    leaves the other alone. If this fails, the on-disk format changed: see
    test_committed_v2_fixture_archive_still_reads in test_archive.py."""
    from bowlrec.archive.migrate import migrate

    expected = json.loads((FIXTURES / "archive-v2.3.json").read_text())
    copy = shutil.copytree(FIXTURES / "archive-v2.3", tmp_path / "archive")
    archive = Archive(copy, create=False)
    assert archive.repair()["damaged_runs"] == []
    assert len(archive) == len(expected) == 9
    blocks = set()
    for rid, want in expected.items():
        stored = archive.load(rid)
        assert stored.attrs["format_version"] == "2.3"
        assert stored.attrs["scene_json"] == want["scene_json"]
        assert stored.scene.name == want["name"]
        assert stored.trajectory.summary.to_dict() == want["summary"]
        assert len(stored.trajectory.events) == want["events"]
        assert stored.trajectory.n_samples == want["samples"]
        located = archive.locate(rid)
        assert located is not None
        with SegmentFile(located[2]) as seg:
            blocks.add(seg.block_runs)
    assert blocks == {1, 256}
    report = migrate(copy)
    assert (report["segments_rewritten"], report["runs"]) == (1, 9)


def _names(rows: list[dict[str, Any]]) -> list[str]:
    return sorted(r["name"] for r in rows)


def test_the_chain_of_formats_from_1_0_reads_into_one_archive(
    tmp_path: Path, plain_run: RunData
) -> None:
    """Format 1.0 migrated, then 2.0, 2.1, 2.2 and 2.3 segments (the committed fixtures) beside
    it and a run with pins written now: every run indexed and read back, and the migration of
    the 2.x archive rewrites every segment of 2.0-2.2, and the 2.3 one with samples, as 3.0
    (with samples) or 2.3: each run reads back the same (tests/test_archive_state.py compares
    every sample quantity)."""
    from bowlrec.archive.migrate import migrate

    root = shutil.copytree(FIXTURES / "archive-v1", tmp_path / "archive")
    assert migrate(root)["runs"] == 2
    for older in ("archive-v2", "archive-v2.1", "archive-v2.2", "archive-v2.3"):
        for seg in (FIXTURES / older / "segments").glob("*.h5"):
            shutil.copy(seg, root / "segments" / seg.name)
    archive = Archive(root)
    archive.reindex()
    archive.add(_with_pins(plain_run, _outcome(), _rid(1)), wall_time_s=0.0)
    rows = archive.list_runs(limit=None)
    assert len(rows) == 2 + 2 + 2 + 3 + 9 + 1
    before = {r["run_id"]: archive.load(r["run_id"]) for r in rows}
    versions = sorted(s.attrs["format_version"] for s in before.values())
    assert versions[:7] == ["2.0"] * 2 + ["2.1"] * 2 + ["2.2"] * 3
    assert set(versions[7:]) == {"2.3", "3.0"}  # 1.0's runs and the new one have samples
    assert archive.repair()["damaged_runs"] == []
    archive.close()
    report = migrate(root)
    assert (report["segments_rewritten"], report["segments_left"], report["runs"]) == (4, 0, 19)
    archive = Archive(root, create=False)
    for rid, old in before.items():
        new = archive.load(rid)
        assert new.attrs["format_version"] in (
            ("3.0",) if old.trajectory.n_samples else ("2.3", "3.0")
        )
        _assert_same_pins(new.trajectory.pins, old.trajectory.pins)
        assert new.trajectory.summary == old.trajectory.summary
        assert new.trajectory.events == old.trajectory.events
        assert new.trajectory.n_samples == old.trajectory.n_samples
        np.testing.assert_array_equal(new.trajectory.position_m, old.trajectory.position_m)
        assert new.scene == old.scene
        assert new.attrs["scene_json"] == old.attrs["scene_json"]
        assert set(new.records) == set(old.records)
    assert archive.repair()["damaged_runs"] == []
    assert migrate(root)["segments_rewritten"] == 0
    assert sorted(r["pinfall"] or 0 for r in archive.list_runs(limit=None))[-3:] == [9, 10, 10]
