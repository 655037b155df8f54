"""Re-recording summary-only archived runs with samples (bowlrec.archive.replay)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers.scene_builders import scene as scene_dict

from bowlrec.api import simulate_into
from bowlrec.archive import Archive
from bowlrec.archive.replay import bowler_report_of, replay_data, rerecord_is_exact
from bowlrec.bowling.scene import BowlerScene
from bowlrec.errors import ConflictError
from bowlrec.sinks.common import RunData
from bowlrec.spec import Scene


def _summary_only(scene: Scene) -> Scene:
    options = scene.options.model_copy(update={"record": "summary"})
    return scene.model_copy(update={"options": options})


def _bowler(handedness: str, record: str = "rate", tilt_deg: float = 0.0) -> Scene:
    bowler = BowlerScene.model_validate(
        {
            "name": f"{handedness}-hander",
            "pap": {"over_in": 5.0, "up_in": 0.5, "handedness": handedness},
            "delivery": {
                "handedness": handedness,
                "laydown_board": 15.0,
                "target_board_at_arrows": 10.0,
                "axis_tilt_deg": tilt_deg,
            },
            "options": {"record": record, "record_dt_s": 0.005},
        }
    )
    return bowler.to_scene()


@pytest.fixture
def archive(tmp_path: Path) -> Archive:
    return Archive(tmp_path / "a")


def test_summary_only_run_is_rerecorded_exactly(archive: Archive) -> None:
    scene = _bowler("right", record="summary")
    added = simulate_into(archive, scene)
    stored = archive.run_data(added.run_id)
    assert stored.trajectory.n_samples == 0
    assert rerecord_is_exact(stored.plan)

    run = replay_data(archive, added.run_id[:10])
    assert run.run_id == added.run_id
    assert run.trajectory.n_samples > 100
    assert np.all(np.diff(run.trajectory.t_s) >= 0.0)
    assert run.trajectory.summary == stored.trajectory.summary  # n_steps and n_rhs included
    assert run.provenance is not None
    assert run.provenance["rerecorded_dt_s"] == 0.005
    for key, value in (stored.provenance or {}).items():
        assert run.provenance[key] == value
    assert run.plan.record_dt_s == 0.005
    assert run.scene.options.record == "rate"

    again = replay_data(archive, added.run_id)
    for name in ("t_s", "position_m", "velocity_mps", "quaternion_wxyz", "omega_radps"):
        assert np.array_equal(getattr(run.trajectory, name), getattr(again.trajectory, name))
    coarse = replay_data(archive, added.run_id, record_dt_s=0.02)
    assert coarse.trajectory.n_samples < run.trajectory.n_samples
    assert coarse.trajectory.summary == stored.trajectory.summary


def test_uniform_ball_is_checked_to_the_tolerance(archive: Archive) -> None:
    scene = Scene.model_validate(scene_dict(record="summary"))
    added = simulate_into(archive, scene)  # the closed form: no steps
    stored = archive.run_data(added.run_id)
    assert not rerecord_is_exact(stored.plan)
    run = replay_data(archive, added.run_id)
    new, old = run.trajectory.summary, stored.trajectory.summary
    assert run.trajectory.n_samples > 100
    assert (new.outcome, new.message, new.n_events) == (old.outcome, old.message, old.n_events)
    assert new.n_steps != old.n_steps
    assert new.slide_m == pytest.approx(old.slide_m, rel=1e-9)


def test_recorded_run_is_returned_unchanged(archive: Archive) -> None:
    added = simulate_into(archive, _bowler("right"))
    stored = archive.run_data(added.run_id)
    run = replay_data(archive, added.run_id)
    assert run.provenance == stored.provenance
    assert "rerecorded_dt_s" not in (run.provenance or {})
    assert np.array_equal(run.trajectory.position_m, stored.trajectory.position_m)
    assert run.trajectory.summary == stored.trajectory.summary


@pytest.mark.parametrize("field", ["hook_m", "n_steps"])
def test_changed_summary_raises_conflict(
    archive: Archive, monkeypatch: pytest.MonkeyPatch, field: str
) -> None:
    from dataclasses import replace

    added = simulate_into(archive, _bowler("right", record="summary"))
    real = Archive.run_data

    def tampered(self: Archive, run_id: str) -> RunData:
        run = real(self, run_id)
        s = run.trajectory.summary
        bumped = getattr(s, field) + (1 if field == "n_steps" else 0.01)
        run.trajectory.summary = replace(s, **{field: bumped})
        return run

    monkeypatch.setattr(Archive, "run_data", tampered)
    with pytest.raises(ConflictError, match=rf"run {added.run_id}: re-recorded {field} .*archived"):
        replay_data(archive, added.run_id)


def test_other_physics_raises_conflict(archive: Archive, monkeypatch: pytest.MonkeyPatch) -> None:
    """A stored run whose scene gives another trajectory: the first differing field is named."""
    added = simulate_into(archive, _bowler("right", record="summary"))
    other = archive.run_data(simulate_into(archive, _bowler("left", record="summary")).run_id)
    real = Archive.run_data

    def swapped(self: Archive, run_id: str) -> RunData:
        run = real(self, run_id)
        return RunData(other.scene, other.plan, run.trajectory, run.run_id, run.provenance)

    monkeypatch.setattr(Archive, "run_data", swapped)
    with pytest.raises(ConflictError, match="differs from the archived"):
        replay_data(archive, added.run_id)


#: a left-hander's delivery is the exact mirror of the right-hander's (tests/test_bowler_facts.py
#: holds the hook to 1e-9 m): measured, the reports' numbers agree to 1.7e-12 (the axis rotation
#: at the breakpoint, in deg; 5.6e-13 with 10 deg of tilt) and the re-recorded paths mirror to
#: 2.5e-14 m, so 1e-10 (report) and 1e-12 m (samples) leave room for rounding only
MIRROR_REPORT = 1e-10
#: the sample times of the two runs may differ by rounding (< MIRROR_T_S, ~ 500 ulp of a second),
#: and a sample's position by the ball's speed (< 10 m/s) times that
MIRROR_T_S = 1e-12
MIRROR_PATH_M = 10.0 * MIRROR_T_S


@pytest.mark.parametrize("tilt_deg", [0.0, 10.0])
def test_bowler_report_of_right_and_left_handers(archive: Archive, tilt_deg: float) -> None:
    reports, runs = {}, {}
    for hand in ("right", "left"):
        added = simulate_into(archive, _bowler(hand, record="summary", tilt_deg=tilt_deg))
        run = replay_data(archive, added.run_id)
        report = bowler_report_of(run)
        assert report is not None
        reports[hand], runs[hand] = report, run
    for hand, report in reports.items():
        assert report["handedness"] == hand
        assert report["outcome"] == "pins"
        assert 14.0 < report["launch_speed_mph"] < 20.0
        assert 200.0 < report["rev_rate_release_rpm"] < 400.0
        assert 1.0 <= report["breakpoint_board"] < report["entry_board"] <= 39.0
        assert report["hook_boards"] > 2.0
        assert 0.0 < report["entry_angle_deg"] < 10.0
        assert 20.0 < report["breakpoint_ft"] < 60.0
        assert report["laydown_board"] == pytest.approx(15.0, abs=MIRROR_REPORT)
        assert report["arrows_board"] == pytest.approx(10.0, abs=1e-6)  # the aim's tolerance
        assert report["axis_tilt_release_deg"] == pytest.approx(tilt_deg, abs=MIRROR_REPORT)
    # the same delivery mirrored: in bowlers' numbers (boards from the bowling hand's gutter,
    # angles toward higher boards) every number is the same
    right, left = reports["right"], reports["left"]
    assert right.keys() == left.keys()
    numbers = [k for k, v in right.items() if isinstance(v, float)]
    assert len(numbers) > 20
    for key in numbers:
        assert left[key] == pytest.approx(right[key], abs=MIRROR_REPORT), key
    assert {k: v for k, v in left.items() if k not in numbers} == {
        **{k: v for k, v in right.items() if k not in numbers},
        "handedness": "left",
    }
    # and on the lane the path is the mirror image through the center line: y -> width - y
    r, l_ = runs["right"].trajectory, runs["left"].trajectory
    width = runs["right"].plan.lane_width_m
    assert r.n_samples == l_.n_samples > 100
    assert np.max(np.abs(r.t_s - l_.t_s)) < MIRROR_T_S
    assert np.max(np.abs(r.position_m[:, 0] - l_.position_m[:, 0])) < MIRROR_PATH_M
    assert np.max(np.abs(r.position_m[:, 1] - (width - l_.position_m[:, 1]))) < MIRROR_PATH_M
    rs, ls = r.summary, l_.summary
    assert rs.hook_m is not None and ls.hook_m is not None and rs.hook_m > 0.0
    assert ls.hook_m == pytest.approx(-rs.hook_m, abs=MIRROR_PATH_M)
    assert rs.pocket_deg is not None and ls.pocket_deg is not None
    assert ls.pocket_deg == pytest.approx(-rs.pocket_deg, abs=MIRROR_REPORT)
    assert ls.slide_m == pytest.approx(rs.slide_m, abs=MIRROR_PATH_M)


def test_bowler_report_of_summary_only_run_is_none(archive: Archive) -> None:
    run = archive.run_data(simulate_into(archive, _bowler("right", record="summary")).run_id)
    assert bowler_report_of(run) is None
