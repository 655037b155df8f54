"""Segment format 3.0: a segment holding samples stores each sample's state, and the other
per-sample quantities are derived on read (docs/archive-format.md, "Samples (3.0)"): a run
written now reads back bit for bit what the simulation gave, a run whose derived quantities
its state does not give back (an older format's, one built by hand) keeps them as stored, and
the committed 3.0 fixture reads."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from helpers.archive_contract import change_value_in_place, seal

import bowlrec
from bowlrec.archive import Archive, run_id
from bowlrec.archive.migrate import migrate
from bowlrec.archive.segment_format import STATE_FIELDS, TRAJECTORY_FIELDS
from bowlrec.core.solver import solve
from bowlrec.errors import RunDamagedError
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import read_run_file
from bowlrec.spec import Scene

FIXTURES = Path(__file__).parent / "fixtures"
DERIVED = sorted(set(TRAJECTORY_FIELDS) - set(STATE_FIELDS))


def _assert_same(new: Any, old: Any) -> None:
    """Two trajectories of one run read back equal, bit for bit."""
    assert new.n_samples == old.n_samples
    for k in TRAJECTORY_FIELDS:
        a, b = getattr(new, k), getattr(old, k)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), k


def test_a_recorded_run_stores_its_state_and_reads_back_bit_for_bit(tmp_path: Path) -> None:
    scene = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.002}})
    plan = scene.resolve()
    traj = solve(plan)
    archive = Archive(tmp_path / "a")
    res = archive.add(RunData(scene, plan, traj, run_id(plan)), wall_time_s=0.0)
    stored = archive.load(res.run_id)
    assert stored.attrs["format_version"] == "3.0"
    assert set(np.unique(traj.phase)) == {0, 1}  # sliding and rolling both derived
    for k, v in traj.arrays().items():
        np.testing.assert_array_equal(stored.trajectory.arrays()[k], v, err_msg=k)
    assert traj.friction_dir is not None and stored.trajectory.friction_dir is not None
    np.testing.assert_array_equal(stored.trajectory.friction_dir, traj.friction_dir)
    located = archive.locate(res.run_id)
    assert located is not None
    with h5py.File(located[2], "r", locking=False) as f:
        assert set(f["trajectory"]) == {*STATE_FIELDS, "offsets"}
        assert f["trajectory/friction_dir"].attrs["units"] == "1"
    assert archive.repair()["damaged_runs"] == []


def test_committed_v3_0_fixture_archive_reads(tmp_path: Path) -> None:
    """tests/fixtures/archive-v3.0 (tests/fixtures/make_fixture_v30.py): a 3.0 segment with two
    recorded runs and a summary-only one, a 2.3 segment of a sweep: every sample reads back
    as it was simulated, bit for bit; a migration leaves them alone. If this fails, the
    on-disk format changed."""
    expected = json.loads((FIXTURES / "archive-v3.0.json").read_text())
    copy = shutil.copytree(FIXTURES / "archive-v3.0", tmp_path / "archive")
    archive = Archive(copy, create=False)
    assert archive.repair()["damaged_runs"] == []
    assert len(archive) == len(expected) == 7
    recorded = 0
    for rid, want in expected.items():
        stored = archive.load(rid)
        assert stored.attrs["format_version"] == want["format_version"]
        assert stored.attrs["scene_json"] == want["scene_json"]
        assert stored.trajectory.summary.to_dict() == want["summary"]
        assert len(stored.trajectory.events) == want["events"]
        arrays = stored.trajectory.arrays()
        for k, values in want["samples"].items():
            assert [float(x).hex() for x in arrays[k].reshape(-1)] == values, k
        recorded += stored.trajectory.n_samples > 0
    assert recorded == 2
    versions = {w["format_version"] for w in expected.values()}
    assert versions == {"2.3", "3.0"}
    assert migrate(copy)["segments_rewritten"] == 0


def test_every_older_format_migrates_to_3_0_and_reads_back_the_same(tmp_path: Path) -> None:
    """The committed fixtures of 1.0 and 2.0-2.3 in one archive, migrated: each run with
    samples reads from its 3.0 copy as it read from the older segment (from the 1.0 run
    file), bit for bit: an older run's friction direction is not the kernel's, so the forces,
    slip, energy and alpha it stored are kept as stored."""
    root = shutil.copytree(FIXTURES / "archive-v1", tmp_path / "archive")
    assert migrate(root)["runs"] == 2
    archive = Archive(root, create=False)
    for path in sorted((root / "v1-archive" / "runs").glob("*/*.h5")):
        old = read_run_file(path)
        if old.trajectory.n_samples:
            new = archive.load(old.run_id)
            assert new.attrs["format_version"] == "3.0"
            _assert_same(new.trajectory, old.trajectory)
    for older in ("archive-v2", "archive-v2.1", "archive-v2.2", "archive-v2.3"):
        for seg in (FIXTURES / older / "segments").glob("*.h5"):
            shutil.copy(seg, root / "segments" / seg.name)
    archive.reindex()
    before = {r["run_id"]: archive.load(r["run_id"]) for r in archive.list_runs(limit=None)}
    with_samples = {k: v for k, v in before.items() if v.trajectory.n_samples}
    old_versions = {v.attrs["format_version"] for v in with_samples.values()}
    assert {"2.0", "2.2", "2.3"} <= old_versions  # recorded runs of older formats are covered
    archive.close()
    migrate(root)
    archive = Archive(root, create=False)
    for rid, old in before.items():
        new = archive.load(rid)
        # a summary-only run in a segment with samples is in a 3.0 segment too
        assert new.attrs["format_version"] in (
            ("3.0",) if old.trajectory.n_samples else ("2.3", "3.0")
        )
        _assert_same(new.trajectory, old.trajectory)
        assert new.trajectory.torques_Nm.keys() == old.trajectory.torques_Nm.keys()
    assert archive.repair()["damaged_runs"] == []
    assert migrate(root)["segments_rewritten"] == 0


def _hand_built(traj: Any) -> Any:
    """``traj`` with its normal force changed by one part in 10**9: a trajectory its state no
    longer gives back."""
    return dataclasses.replace(traj, normal_force_N=traj.normal_force_N * (1.0 + 1e-9))


def test_derived_quantities_the_state_does_not_give_are_stored_as_given(tmp_path: Path) -> None:
    """A segment with one kernel run and one run whose normal force is not what its state
    gives: both read back bit for bit (the segment stores every run's derived quantities), a
    segment of kernel runs alone stores the state only, and the stored derived quantities are
    under the digest (a changed value is damage)."""
    scene = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.01}})
    other = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.02}})
    runs = [
        RunData(s, s.resolve(), solve(s.resolve()), run_id(s.resolve())) for s in (scene, other)
    ]
    changed = dataclasses.replace(runs[1], trajectory=_hand_built(runs[1].trajectory))
    archive = Archive(tmp_path / "a")
    both = seal(archive, [runs[0], changed])
    alone = seal(archive, [dataclasses.replace(runs[0], run_id="cd" * 10)])
    for run in (runs[0], changed):
        _assert_same(archive.load(run.run_id or "").trajectory, run.trajectory)
    with h5py.File(both, "r", locking=False) as f:
        assert set(f["trajectory"]) == {*STATE_FIELDS, *DERIVED, "offsets"}
        assert f["trajectory/normal_force_N"].attrs["units"] == "N"
    with h5py.File(alone, "r", locking=False) as f:
        assert set(f["trajectory"]) == {*STATE_FIELDS, "offsets"}
    assert archive.repair()["damaged_runs"] == []
    archive.close()
    change_value_in_place(both, "trajectory/energy_J", 3)
    archive = Archive(tmp_path / "a", create=False)
    with pytest.raises(RunDamagedError):
        archive.load(runs[0].run_id or "")


def test_a_kernel_trajectory_is_marked_derived_until_its_arrays_change() -> None:
    """The kernel's trajectory is marked as derived from its state (the writer then stores the
    state without deriving again): its per-sample arrays are read-only, and the mark is gone
    once an array is replaced or the trajectory is copied with dataclasses.replace
    (Trajectory.replaced keeps it when the samples stay)."""
    plan = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.01}}).resolve()
    traj = solve(plan)
    assert traj.derived_from_state()
    with pytest.raises(ValueError, match="read-only"):
        traj.energy_J[0] = 0.0
    assert not dataclasses.replace(traj).derived_from_state()
    assert traj.replaced(summary=traj.summary).derived_from_state()  # the samples unchanged
    assert not traj.replaced(energy_J=traj.energy_J.copy()).derived_from_state()
    assert bowlrec.simulate(
        Scene.model_validate({"options": {"record": "rate"}})
    ).derived_from_state()
    traj.energy_J = traj.energy_J.copy()
    assert not traj.derived_from_state()


def test_solve_state_is_solve_without_the_derived_quantities() -> None:
    """solve_state gives the state solve gives, bit for bit, and run_plan's summary and events,
    without deriving the rest; a plan recording per-term torques is refused (they are derived
    from the state)."""
    from bowlrec.core.solver import run_plan, solve_state

    plan = Scene.model_validate({"options": {"record": "rate", "record_dt_s": 0.005}}).resolve()
    traj, state = solve_state(plan)
    full = run_plan(plan)
    assert traj.n_samples == 0 and set(state) == set(STATE_FIELDS)
    assert traj.summary == full.summary and traj.events == full.events
    assert full.friction_dir is not None
    for k, arr in state.items():
        want = full.friction_dir if k == "friction_dir" else getattr(full, k)
        assert arr.dtype == want.dtype and arr.tobytes() == want.tobytes(), k
    terms = Scene.model_validate({"options": {"record": "rate", "record_terms": True}})
    with pytest.raises(ValueError, match="torques"):
        solve_state(terms.resolve())
