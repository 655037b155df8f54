"""A run's pins in the one-run file exports: the HDF5 run file (format ``bowlrec-run`` 1.1: a
``/pins`` group, every dataset with its units, read back into an equal ``PinOutcome``), the
``.npz`` (``pins_json`` and the ``pins/...`` arrays) and the scene JSON (its ``options.pins``
simulates to the same pins). A run without pins is written as before: format 1.0, nothing added.

The real engine runs twice (one flush pocket shot, ``max_time_s`` 1 s, and the JSON export
simulated again), skipped without the pins extra; the archived runs exported come from the
committed 2.2 fixture (no MuJoCo).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

import bowlrec.pins  # noqa: F401  (MUJOCO_GL=disable before MuJoCo loads)
from bowlrec.archive import Archive
from bowlrec.pins.outcome import PinOutcome
from bowlrec.pins.records import pin_groups
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import (
    FORMAT_VERSION,
    PINS_FORMAT_VERSION,
    read_run_file,
    write_run_file,
)
from bowlrec.sinks.registry import sink_for

HERE = Path(__file__).parent
ROOT = HERE.parent
FIXTURES = HERE / "fixtures"
SAMPLE_FIELDS = (
    "t_s",
    "pin_position_m",
    "pin_quaternion_wxyz",
    "ball_position_m",
    "ball_quaternion_wxyz",
    "energy_J",
)
ATTRS = {"created_at": "2026-01-01T00:00:00Z", "bowlrec_version": "test"}


def _pin_scene_data() -> dict[str, Any]:
    """examples/bowler/pocket-right.json through the pins (lane every 10 ms, pins every 5 ms,
    at most 1 s of pin action)."""
    data = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    data.setdefault("options", {}).update(record="rate", record_dt_s=0.01)
    data["options"]["pins"] = {"record_dt_s": 0.005, "max_time_s": 1.0}
    return data


@pytest.fixture(scope="module")
def run() -> RunData:
    pytest.importorskip("mujoco", reason="pin action needs the pins extra")
    from bowlrec.api import as_scene, simulate

    scene = as_scene(_pin_scene_data())
    return RunData(scene=scene, plan=scene.resolve(), trajectory=simulate(scene))


def _without_pins(run: RunData) -> RunData:
    return RunData(
        scene=run.scene,
        plan=dataclasses.replace(run.plan, pins=None),
        trajectory=dataclasses.replace(run.trajectory, pins=None),
    )


def assert_same_pins(got: PinOutcome | None, want: PinOutcome) -> None:
    """Every value and array of ``got`` equal to ``want``'s (NaN equal to NaN)."""
    assert got is not None
    assert got.to_dict() == want.to_dict()
    assert got.entry == want.entry
    if want.action is None:
        assert got.action is None
        return
    assert got.action is not None
    for f in dataclasses.fields(want.action):
        a, b = getattr(got.action, f.name), getattr(want.action, f.name)
        if isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), f.name
        else:
            assert a == b, f.name


def _tree(path: Path) -> dict[str, Any]:
    """Every object of an HDF5 file: name -> (its attributes, its data or None for a group)."""
    out: dict[str, Any] = {}
    with h5py.File(path, "r") as f:

        def visit(name: str, obj: Any) -> None:
            attrs = {k: np.asarray(v).tolist() for k, v in obj.attrs.items()}
            data = obj[()] if isinstance(obj, h5py.Dataset) else None
            out[name] = (attrs, data)

        visit("/", f)
        f.visititems(visit)
    return out


# -- HDF5 ------------------------------------------------------------------------------------------


def test_a_pin_run_file_holds_the_pins_with_units_and_reads_back_equal(
    run: RunData, tmp_path: Path
) -> None:
    pins = run.trajectory.pins
    assert pins is not None and pins.action is not None and pins.entry is not None
    path = sink_for("run.h5").write(run, tmp_path / "run.h5")
    with h5py.File(path, "r") as f:
        assert f.attrs["format_version"] == PINS_FORMAT_VERSION
        assert f.attrs["pin_engine_version"] == pins.action.engine
        assert run.plan.pins is not None
        assert json.loads(f["resolved"].attrs["pins_json"]) == json.loads(
            json.dumps(dataclasses.asdict(run.plan.pins))
        )
        g = f["pins"]
        assert json.loads(g.attrs["outcome_json"]) == json.loads(json.dumps(pins.to_dict()))
        n = pins.action.t_s.shape[0]
        assert g["pin_position_m"].shape == (n, 10, 3)
        assert g["pin_quaternion_wxyz"].shape == (n, 10, 4)
        assert g["ball_position_m"].shape == (n, 3) and g["energy_J"].shape == (n,)
        for name, arr in pin_groups(pins)["pins"].items():
            assert np.array_equal(g[name][()], arr, equal_nan=True), name
        assert g["outcome/leave"].asstr()[()] == pins.leave == "strike"
        assert int(g["outcome/pinfall"][()]) == pins.pinfall == 10
        assert [p for p in g["outcome/touched"][()] if p] == list(pins.touched)
        assert g["action/engine"].asstr()[()] == pins.action.engine
        assert np.array_equal(g["entry/quaternion_wxyz"][()], pins.entry.quaternion_wxyz)
        units = {
            "t_s": "s",
            "pin_position_m": "m",
            "pin_quaternion_wxyz": "1",
            "energy_J": "J",
            "outcome/exit_board": "board",
            "outcome/deflection_boards": "board",
            "action/wall_time_s": "s",
            "action/exit_y_m": "m",
            "entry/velocity_mps": "m/s",
            "entry/omega_radps": "rad/s",
            "entry/deck_friction": "1",
        }
        for name, want in units.items():
            assert g[name].attrs["units"] == want, name
        missing: list[str] = []

        def check(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset) and "units" not in obj.attrs:
                missing.append(name)

        f.visititems(check)
        assert missing == []
    stored = read_run_file(path)
    assert stored.scene == run.scene
    assert_same_pins(stored.trajectory.pins, pins)


def test_pins_only_add_to_the_run_file_and_a_run_without_them_is_written_as_before(
    run: RunData, tmp_path: Path
) -> None:
    """The same run without its pins: format 1.0, no ``/pins``, ``pins_is_none`` as before;
    every other object, attribute and value equal to the pin file's; the same bytes each time
    (the writer's output for a run without pins was checked byte for byte against the code
    before pins were exported)."""
    with_pins = write_run_file(tmp_path / "pins.h5", run, ATTRS)
    plain = _without_pins(run)
    a = write_run_file(tmp_path / "a.h5", plain, ATTRS)
    b = write_run_file(tmp_path / "b.h5", plain, ATTRS)
    assert a.read_bytes() == b.read_bytes()
    old, new = _tree(a), _tree(with_pins)
    assert "pins" not in old and old["/"][0]["format_version"] == FORMAT_VERSION == "1.0"
    assert old["resolved"][0]["pins_is_none"] is True
    added = {k for k in new if k == "pins" or k.startswith("pins/")}
    assert added and set(new) - added == set(old)
    assert set(new["/"][0]) - set(old["/"][0]) == {"pin_engine_version"}
    assert new["resolved"][0].pop("pins_json") and old["resolved"][0].pop("pins_is_none")
    new["/"][0].pop("pin_engine_version")
    new["/"][0]["format_version"] = "1.0"
    for name, (attrs, data) in old.items():
        if name == "/":
            attrs, new_attrs = dict(attrs), dict(new[name][0])
            for key in ("summary_json", "scene_json"):  # the summary is the lane's either way
                assert attrs.pop(key) == new_attrs.pop(key)
            assert attrs == new_attrs
            continue
        assert attrs == new[name][0], name
        if data is not None:
            assert np.array_equal(np.asarray(data), np.asarray(new[name][1])), name
    assert read_run_file(a).trajectory.pins is None


def test_archived_pin_runs_export_with_their_pins(tmp_path: Path) -> None:
    """``runs export ID --out run.h5`` of the committed 2.2 fixture's three runs: recorded pin
    action (every sample), summary-only (where the pins came to rest) and without pins."""
    expected = json.loads((FIXTURES / "archive-v2.2.json").read_text())
    archive = Archive(shutil.copytree(FIXTURES / "archive-v2.2", tmp_path / "a"), create=False)
    for name, want in expected.items():
        path = archive.export(want["run_id"], tmp_path / f"{name}.h5")
        stored = read_run_file(path)
        assert stored.run_id == want["run_id"] and stored.scene.name == name
        pins, was = stored.trajectory.pins, archive.load(want["run_id"]).trajectory.pins
        with h5py.File(path, "r") as f:
            if was is None:
                assert pins is None and "pins" not in f
                assert f.attrs["format_version"] == FORMAT_VERSION
                continue
            assert f.attrs["format_version"] == PINS_FORMAT_VERSION
            assert f["pins/t_s"].shape == (want["pin_samples"],)
        assert pins is not None and pins.to_dict() == want["pins"]
        assert_same_pins(pins, was)


# -- NPZ and JSON ----------------------------------------------------------------------------------


def test_npz_holds_the_pins_and_a_run_without_them_is_written_as_before(
    run: RunData, tmp_path: Path
) -> None:
    pins = run.trajectory.pins
    assert pins is not None and pins.action is not None and pins.entry is not None
    path = sink_for("run.npz").write(run, tmp_path / "run.npz")
    plain = sink_for("run.npz").write(_without_pins(run), tmp_path / "plain.npz")
    with np.load(path) as z, np.load(plain) as p:
        plain_keys = set(p.files)
        assert "pins_json" not in plain_keys and not any(k.startswith("pins/") for k in p.files)
        assert set(z.files) - plain_keys == {"pins_json", *(f"pins/{n}" for n in SAMPLE_FIELDS)}
        for key in plain_keys:
            assert np.array_equal(z[key], p[key], equal_nan=z[key].dtype.kind == "f"), key
        for name, arr in pin_groups(pins)["pins"].items():
            assert np.array_equal(z[f"pins/{name}"], arr, equal_nan=True), name
        values = json.loads(str(z["pins_json"]))
    assert values["outcome"] == json.loads(json.dumps(pins.to_dict()))
    assert values["action"]["engine"] == pins.action.engine
    assert values["action"]["n_steps"] == pins.action.n_steps
    assert values["action"]["exit_y_m"] == pins.action.exit_y_m
    assert values["entry"] == json.loads(json.dumps(dataclasses.asdict(pins.entry)))


def test_the_json_export_simulates_to_the_same_pins(run: RunData, tmp_path: Path) -> None:
    """The scene JSON holds ``options.pins`` (the pin model's parameters), so simulating the file
    again gives the same run ID and the same pins, sample for sample."""
    from bowlrec.api import as_scene, simulate
    from bowlrec.archive.run_id import run_id

    path = sink_for("run.json").write(run, tmp_path / "run.json")
    scene = as_scene(json.loads(path.read_text()))
    assert scene.resolve().pins == run.plan.pins is not None
    assert run_id(scene.resolve()) == run_id(run.plan)
    again = simulate(scene).pins
    assert again is not None and again.action is not None and run.trajectory.pins is not None
    got, want = dataclasses.replace(again.action, wall_time_s=0.0), run.trajectory.pins.action
    assert want is not None  # the engine's wall time is the one value that differs
    assert_same_pins(
        dataclasses.replace(again, action=got),
        dataclasses.replace(run.trajectory.pins, action=dataclasses.replace(want, wall_time_s=0.0)),
    )


def test_a_ball_that_never_reached_the_pins_keeps_its_outcome(tmp_path: Path) -> None:
    """A pin outcome without pin action (a gutter ball): ``/pins`` holds the outcome only."""
    expected = json.loads((FIXTURES / "archive-v2.2.json").read_text())
    archive = Archive(shutil.copytree(FIXTURES / "archive-v2.2", tmp_path / "a"), create=False)
    data = archive.run_data(expected["fixture-no-pins"]["run_id"])
    pins = tuple(range(1, 11))
    outcome = PinOutcome(pins, pins, "gutter", "right", (), None, None, None, None)
    run = RunData(data.scene, data.plan, dataclasses.replace(data.trajectory, pins=outcome))
    path = write_run_file(tmp_path / "run.h5", run, ATTRS)
    with h5py.File(path, "r") as f:
        assert f.attrs["format_version"] == PINS_FORMAT_VERSION
        assert "pin_engine_version" not in f.attrs
        assert sorted(f["pins"]) == ["outcome"]
        assert np.isnan(f["pins/outcome/exit_board"][()])
    assert_same_pins(read_run_file(path).trajectory.pins, outcome)
