"""Outputs in bowlers' terms: checked against straight-line geometry and the physics summary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bowlrec.api import simulate
from bowlrec.bowling.delivery import BowlerDelivery, hooking_delivery
from bowlrec.bowling.lane import BowlerLane, Handedness
from bowlrec.bowling.report import BowlerReport, bowler_report, observed_run
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import SamplesRequiredError
from bowlrec.spec import Ball, Scene
from bowlrec.units import ARROWS_FT, FT_M, MPH_MPS, RPM_RADPS

LANE = BowlerLane()
RADIUS_M = 0.1085
#: a right-hander's hooking delivery: from board 15 over the second arrow, 45 deg rotation
HOOK = hooking_delivery()


def _run(bd: BowlerDelivery, record: str = "steps", dt_s: float = 0.001) -> Trajectory:
    scene = Scene(
        ball=Ball(radius_m=RADIUS_M),
        lane=LANE.to_physical(),
        delivery=bd.to_physical(LANE),
        options={"record": record, "record_dt_s": dt_s},  # type: ignore[arg-type]
    )
    return simulate(scene)


def _rolling(**fields: float) -> BowlerDelivery:
    """A forward roll with omega R = v at 17 mph: no slip, no lateral force, a straight path."""
    speed_mph = 17.0
    return BowlerDelivery.model_validate(
        {
            "speed_mph": speed_mph,
            "rev_rate_rpm": speed_mph * MPH_MPS / RADIUS_M / RPM_RADPS,
            "axis_rotation_deg": 0.0,
            "axis_tilt_deg": 0.0,
            **fields,
        }
    )


@pytest.fixture(scope="module")
def hooks() -> dict[Handedness, tuple[Trajectory, BowlerReport]]:
    out: dict[Handedness, tuple[Trajectory, BowlerReport]] = {}
    for bd in (HOOK, HOOK.mirrored()):
        trajectory = _run(bd)
        out[bd.handedness] = (trajectory, bowler_report(trajectory, LANE, bd.handedness))
    return out


def test_straight_ball_down_the_boards() -> None:
    report = bowler_report(_run(_rolling(laydown_board=17.5)), LANE)
    assert report.outcome == "pins"
    assert report.slide_ft == pytest.approx(0.0, abs=1e-9)  # it rolls from the release
    assert report.launch_angle_deg == 0.0
    for board in (report.arrows_board, report.entry_board, report.breakpoint_board):
        assert board == pytest.approx(17.5, abs=1e-9)
    assert report.entry_angle_deg == pytest.approx(0.0, abs=1e-9)
    assert report.hook_boards == pytest.approx(0.0, abs=1e-9)
    assert report.breakpoint_ft == 0.0  # no turning point: the release is the outermost point
    assert report.entry_speed_mph == pytest.approx(17.0, abs=1e-9)
    assert report.rev_rate_pins_rpm == pytest.approx(report.rev_rate_release_rpm, abs=1e-9)
    assert report.axis_rotation_pins_deg == pytest.approx(0.0, abs=1e-9)
    assert report.axis_tilt_pins_deg == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_straight_angled_ball_crosses_the_extrapolated_boards(hand: Handedness) -> None:
    bd = _rolling(laydown_board=10.0, laydown_ft=1.0, target_board_at_arrows=12.0)
    bd = bd.model_copy(update={"handedness": hand})
    report = bowler_report(_run(bd), LANE, hand)
    launch = bd.launch_angle_on(LANE)
    slope_boards_per_ft = math.tan(math.radians(launch)) * FT_M / LANE.board_width_m
    assert launch > 0.0  # inward: toward higher boards
    assert report.launch_angle_deg == pytest.approx(launch, abs=1e-9)
    assert report.laydown_board == pytest.approx(10.0, abs=1e-12)
    assert report.laydown_ft == pytest.approx(1.0, abs=1e-12)
    assert report.arrows_board == pytest.approx(12.0, abs=1e-9)
    entry = 10.0 + slope_boards_per_ft * (60.0 - 1.0)
    assert report.entry_board == pytest.approx(entry, abs=1e-9)
    assert report.entry_angle_deg == pytest.approx(launch, abs=1e-9)
    # moving inward from the release: the breakpoint is the laydown point
    assert report.breakpoint_board == pytest.approx(10.0, abs=1e-12)
    assert report.breakpoint_ft == pytest.approx(1.0, abs=1e-12)
    assert report.hook_boards == pytest.approx(entry - 10.0, abs=1e-9)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_hooking_ball_agrees_with_the_physics_summary(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]], hand: Handedness
) -> None:
    trajectory, report = hooks[hand]
    summary = trajectory.summary
    assert summary.outcome == report.outcome == "pins"
    assert summary.pocket_deg is not None and summary.slide_m is not None
    sign = 1.0 if hand == "right" else -1.0
    assert report.entry_angle_deg == pytest.approx(sign * summary.pocket_deg, abs=1e-9)
    assert report.entry_angle_deg is not None and report.entry_angle_deg > 1.0
    assert report.entry_board == pytest.approx(LANE.y_to_board(summary.y_end_m, hand), abs=1e-9)
    assert report.entry_speed_mph == pytest.approx(summary.speed_end_mps / MPH_MPS, abs=1e-9)
    assert report.rev_rate_pins_rpm == pytest.approx(summary.rev_rate_end_rpm, abs=1e-9)
    assert report.slide_ft == pytest.approx(summary.slide_m / FT_M, abs=1e-12)
    # release: what the bowler delivered
    assert report.launch_speed_mph == pytest.approx(17.0, abs=1e-12)
    assert report.rev_rate_release_rpm == pytest.approx(300.0, abs=1e-9)
    assert report.axis_rotation_release_deg == pytest.approx(45.0, abs=1e-9)
    assert report.axis_tilt_release_deg == pytest.approx(10.0, abs=1e-9)
    assert report.launch_angle_deg == pytest.approx(HOOK.launch_angle_on(LANE), abs=1e-9)
    # the ball rolls at the pins: its axis has migrated to end over end (rotation 0)
    assert report.axis_rotation_pins_deg == pytest.approx(0.0, abs=1e-6)
    assert report.axis_rotation_breakpoint_deg is not None
    assert 0.0 < report.axis_rotation_breakpoint_deg < 45.0
    # the hook: out to the breakpoint, back to the pocket
    assert report.hook_boards is not None and report.hook_boards > 5.0
    assert report.breakpoint_board < report.laydown_board
    assert 15.0 < report.breakpoint_ft < 60.0


def test_breakpoint_is_the_turning_point(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]],
) -> None:
    trajectory, report = hooks["right"]
    boards = np.array([LANE.y_to_board(float(y)) for y in trajectory.position_m[:, 1]])
    k = int(np.argmin(boards))
    assert 0 < k < trajectory.n_samples - 1
    # at or just below the lowest sample; the velocity turns there
    assert boards[k] - 1e-3 < report.breakpoint_board <= boards[k]
    x_ft = trajectory.position_m[:, 0] / FT_M
    assert x_ft[k - 1] <= report.breakpoint_ft <= x_ft[k + 1]
    assert trajectory.velocity_mps[k - 1, 1] <= 0.0 <= trajectory.velocity_mps[k + 1, 1]
    # a finely sampled run (1 ms) puts it at the same place
    fine = bowler_report(_run(HOOK, record="rate", dt_s=0.001), LANE)
    assert fine.breakpoint_board == pytest.approx(report.breakpoint_board, abs=1e-6)
    assert fine.breakpoint_ft == pytest.approx(report.breakpoint_ft, abs=1e-3)
    assert fine.arrows_board == pytest.approx(report.arrows_board, abs=1e-6)


def test_left_hander_report_equals_the_right_hander_report(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]],
) -> None:
    right, left = hooks["right"][1].to_dict(), hooks["left"][1].to_dict()
    assert right.pop("handedness") == "right"
    assert left.pop("handedness") == "left"
    for key, value in right.items():
        if isinstance(value, float):
            assert left[key] == pytest.approx(value, abs=1e-9), key
        else:
            assert left[key] == value, key


def test_arrows_board_and_units_in_names(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]],
) -> None:
    trajectory, report = hooks["right"]
    # the hook has already started on the oil by the arrows (rotation 45 deg, mu = 0.04)
    x = trajectory.position_m[:, 0]
    j = int(np.flatnonzero(x >= ARROWS_FT * FT_M)[0])
    lo, hi = sorted(LANE.y_to_board(float(y)) for y in trajectory.position_m[j - 1 : j + 1, 1])
    assert report.arrows_board is not None and lo <= report.arrows_board <= hi
    names = report.to_dict().keys()
    for name in names - {"handedness", "outcome", "hook_boards"}:
        assert name.endswith(("_board", "_ft", "_mph", "_rpm", "_deg")), name


def test_gutter_ball_has_no_entry() -> None:
    # a straight roll angled out to the right gutter
    bd = _rolling(laydown_board=10.0, launch_angle_deg=-3.0)
    report = bowler_report(_run(bd), LANE)
    assert report.outcome == "gutter"
    assert report.entry_board is None and report.entry_angle_deg is None
    assert report.hook_boards is None and report.axis_rotation_pins_deg is None
    assert report.arrows_board is not None
    assert report.breakpoint_board == pytest.approx(0.5, abs=1e-9)  # at the lane edge


def test_summary_only_runs_without_observations_are_refused() -> None:
    trajectory = _run(HOOK, record="summary")
    with pytest.raises(SamplesRequiredError, match="record = 'summary'"):
        bowler_report(trajectory, LANE)


def _observed(bd: BowlerDelivery) -> Trajectory:
    scene = Scene(
        ball=Ball(radius_m=RADIUS_M), lane=LANE.to_physical(), delivery=bd.to_physical(LANE),
        options={"record": "summary"},  # type: ignore[arg-type]
    )  # fmt: skip
    return observed_run(scene.resolve(), LANE)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_specto_windows_of_a_straight_roll_are_its_line(hand: Handedness) -> None:
    """A rolling uniform ball keeps its speed and direction: every window reads the line."""
    bd = _rolling(laydown_board=10.0, laydown_ft=1.0, target_board_at_arrows=12.0)
    bd = bd.model_copy(update={"handedness": hand})
    launch = bd.launch_angle_on(LANE)
    slope = math.tan(math.radians(launch)) * FT_M / LANE.board_width_m  # boards per ft
    for report in (bowler_report(_run(bd), LANE, hand), bowler_report(_observed(bd), LANE, hand)):
        for angle in (
            report.specto_launch_angle_deg, report.specto_entry_angle_deg,
            report.specto_impact_angle_deg,
        ):  # fmt: skip
            assert angle == pytest.approx(launch, abs=1e-9)
        assert report.specto_launch_speed_mph == pytest.approx(17.0, abs=1e-9)
        assert report.specto_entry_speed_mph == pytest.approx(17.0, abs=1e-9)
        assert report.specto_entry_board == pytest.approx(10.0 + slope * 58.5, abs=1e-9)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_the_report_from_observations_equals_the_report_from_samples(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]], hand: Handedness
) -> None:
    """The kernel's observations (summary only, exact dense output at the stations) against
    the recorded path (cubic Hermite between steps): the same definitions, two sources."""
    bd = HOOK if hand == "right" else HOOK.mirrored()
    from_samples = hooks[hand][1].to_dict()
    observed = _observed(bd)
    assert observed.n_samples == 0
    from_observations = bowler_report(observed, LANE, hand).to_dict()
    for key, value in from_samples.items():
        if not isinstance(value, float):
            assert from_observations[key] == value, key
        elif "axis" in key and "breakpoint" in key:
            # omega is interpolated linearly between samples
            assert from_observations[key] == pytest.approx(value, abs=0.02), key
        else:
            assert from_observations[key] == pytest.approx(value, abs=2e-6), key


def test_specto_entry_windows_read_the_straight_roll_after_the_hook(
    hooks: dict[Handedness, tuple[Trajectory, BowlerReport]],
) -> None:
    """A uniform ball that rolls before 51 ft goes straight from there: both entry windows
    read the entry angle, and the board at 59.5 ft lies on the entry line."""
    r = hooks["right"][1]
    assert r.slide_ft is not None and r.slide_ft < 51.0
    assert r.entry_angle_deg is not None and r.entry_board is not None
    assert r.specto_entry_angle_deg == pytest.approx(r.entry_angle_deg, abs=1e-9)
    assert r.specto_impact_angle_deg == pytest.approx(r.entry_angle_deg, abs=1e-9)
    slope = math.tan(math.radians(r.entry_angle_deg)) * FT_M / LANE.board_width_m
    assert r.specto_entry_board == pytest.approx(r.entry_board - 0.5 * slope, abs=1e-9)


def test_specto_entry_angle_lags_the_exact_one_for_a_ball_still_hooking() -> None:
    """The pocket example rolls from ~54 ft and its unequal moments of inertia keep turning it
    after that: Specto's windows read the growing angle below the exact one at 60 ft."""
    import json
    from pathlib import Path

    from bowlrec.bowling.scene import BowlerScene

    path = Path(__file__).parents[1] / "examples" / "bowler" / "pocket-right.json"
    scene = BowlerScene.model_validate(json.loads(path.read_text()))
    plan = scene.to_scene().resolve()
    r = bowler_report(observed_run(plan, scene.lane), scene.lane, "right")
    assert r.slide_ft is not None and 51.0 < r.slide_ft < 57.0
    assert r.entry_angle_deg is not None and r.specto_entry_angle_deg is not None
    assert r.specto_impact_angle_deg is not None
    assert r.specto_entry_angle_deg < r.specto_impact_angle_deg < r.entry_angle_deg - 0.1
