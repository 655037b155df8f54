"""Events and hard cases: each with the behaviour it must show, not just "does not crash"."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.scene_builders import scene

from bowlrec import simulate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "paper"
R = 0.1085
G = 9.81
W = 1.0668


def paper_case(n: int) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((EXAMPLES / f"case{n:02d}.json").read_text())
    return data


def test_pins_summary_taken_exactly_at_the_foul_line_distance() -> None:
    tr = simulate(paper_case(16))
    assert tr.summary.outcome == "pins"
    assert tr.summary.x_end_m == pytest.approx(18.288, abs=1e-9)
    assert tr.events[-1].kind == "pins"
    assert tr.t_s[-1] == pytest.approx(tr.summary.time_s)


def test_gutter_outcome_located_on_the_edge() -> None:
    tr = simulate(scene(angle=-3.0, position=(0.0, 0.2), omega=(0.0, 30.0, 0.0)))
    assert tr.summary.outcome == "gutter"
    assert tr.summary.y_end_m == pytest.approx(0.0, abs=1e-9)
    assert tr.summary.hook_m is None and tr.summary.pocket_deg is None
    assert tr.events[-1].kind == "gutter"


def test_strong_backspin_stops_before_the_pins() -> None:
    tr = simulate(scene(speed=2.0, omega=(0.0, -80.0, 0.0), mu=0.2))
    assert tr.summary.outcome == "stopped"
    assert tr.velocity_mps[-1, 0] == pytest.approx(0.0, abs=1e-9)
    assert tr.summary.x_end_m < 18.288


def test_high_spin_on_a_large_offset_is_airborne_with_a_clear_message() -> None:
    # omega^2 |offset| = 40^2 * 0.02 = 32 m/s^2 > g: the lane would have to pull the ball down
    tr = simulate(scene(omega=(0.0, 40.0, 0.0), offset=(0.02, 0.0, 0.0), speed=5.0))
    assert tr.summary.outcome == "airborne"
    assert "normal force" in tr.summary.message
    assert np.all(np.isfinite(tr.position_m))
    assert tr.normal_force_N[-1] == pytest.approx(0.0, abs=1e-6)
    assert np.all(tr.normal_force_N[:-1] > 0.0)


def test_zone_crossings_are_located_on_the_boundary() -> None:
    friction = {
        "kind": "zones",
        "default_mu": 0.2,
        "zones": [{"x_min_m": -1.0, "x_max_m": 5.0, "y_min_m": -1.0, "y_max_m": 2.0, "mu": 0.04}],
    }
    tr = simulate(scene(mu=friction, omega=(-30.0, 0.0, 0.0), angle=-1.0))
    zone = [e for e in tr.events if e.kind == "zone"]
    assert len(zone) == 1
    assert zone[0].x_m == pytest.approx(5.0, abs=1e-10)
    assert zone[0].mu == 0.2
    # samples before the crossing carry the oiled mu, after it the dry one
    assert set(np.unique(tr.mu[tr.t_s < zone[0].t_s])) == {0.04}
    assert set(np.unique(tr.mu[tr.t_s > zone[0].t_s])) == {0.2}


def test_release_exactly_on_a_zone_boundary_takes_the_zone_it_moves_into() -> None:
    typical = {"kind": "typical"}
    edge = 0.5 * W * (1.0 - 0.8)
    on_edge = simulate(scene(mu=typical, omega=(-30.0, 0.0, 0.0), angle=-2.0, position=(0.0, edge)))
    inside_dry = simulate(
        scene(mu=typical, omega=(-30.0, 0.0, 0.0), angle=-2.0, position=(0.0, edge - 1e-13))
    )
    assert on_edge.mu[1] == 0.2
    assert on_edge.summary.outcome == inside_dry.summary.outcome
    assert on_edge.summary.y_end_m == pytest.approx(inside_dry.summary.y_end_m, abs=1e-9)


def test_paper_threshold_rule_rolls_earlier_by_the_closed_form_amount() -> None:
    exact = simulate(scene(slide_to_roll="exact")).summary
    paper = simulate(scene(slide_to_roll="threshold", slip_threshold_mps=0.01)).summary
    rate = 0.12 * G * (1.0 + R**2 / 0.067**2)  # |ds/dt| for a uniform ball
    t_star = (8.0 - 30.0 * R) / rate
    t_thr = t_star - 0.01 / rate
    x = lambda t: 8.0 * t - 0.5 * 0.12 * G * t * t  # noqa: E731
    assert exact.slide_m == pytest.approx(x(t_star), rel=1e-9)
    assert paper.slide_m == pytest.approx(x(t_thr), rel=1e-9)


def test_paper_threshold_rule_rolls_at_release_when_the_slip_starts_under_it() -> None:
    """The release slip is 8 - 30 R m/s (about 4.75). Just under it the threshold shortens the
    slide to the closed form's few centimetres; at or above it the ball rolls from release: a
    slide -> roll event at t = 0 and no slide, continuous with the threshold below."""
    s0 = 8.0 - 30.0 * R
    rate = 0.12 * G * (1.0 + R**2 / 0.067**2)
    x = lambda t: 8.0 * t - 0.5 * 0.12 * G * t * t  # noqa: E731
    below = simulate(scene(slide_to_roll="threshold", slip_threshold_mps=s0 - 0.05))
    assert below.summary.slide_m == pytest.approx(x(0.05 / rate), rel=1e-9)
    for threshold in (s0 + 1e-3, 100.0):
        run = simulate(scene(slide_to_roll="threshold", slip_threshold_mps=threshold))
        assert run.summary.slide_m == 0.0
        assert (run.events[0].kind, run.events[0].t_s) == ("slide_to_roll", 0.0)


def test_rolling_ball_entering_oil_starts_sliding() -> None:
    # a non-uniform ball rolling on a dry zone needs friction (tau_dev); on near-frictionless oil
    # it cannot keep rolling
    omega = (-3.0, 30.0, 5.0)
    v = (R * omega[1], -R * omega[0])
    speed = math.hypot(*v)
    angle = math.degrees(math.atan2(v[1], v[0]))
    friction = {
        "kind": "zones",
        "default_mu": 0.001,
        "zones": [{"x_min_m": -1.0, "x_max_m": 3.0, "y_min_m": -5.0, "y_max_m": 5.0, "mu": 0.3}],
    }
    tr = simulate(
        scene(
            mu=friction,
            omega=omega,
            speed=speed,
            angle=angle,
            rg=(0.062, 0.066, 0.068),
            axis_1=(0.6, 0.8, 0.0),
            axis_2=(-0.8, 0.6, 0.0),
        )
    )
    kinds = [e.kind for e in tr.events]
    assert kinds[:2] == ["zone", "roll_to_slide"], kinds
    assert tr.events[1].t_s == tr.events[0].t_s
    assert tr.phase[0] == 1  # released rolling


def test_zero_spin_slides_then_rolls_without_nan() -> None:
    tr = simulate(scene(omega=(0.0, 0.0, 0.0)))
    rate = 0.12 * G * (1.0 + R**2 / 0.067**2)
    t_star = 8.0 / rate
    assert tr.summary.slide_m == pytest.approx(8.0 * t_star - 0.06 * G * t_star**2, rel=1e-9)
    assert np.all(np.isfinite(tr.quaternion_wxyz))


def test_principal_axis_aligned_with_forward_spin_does_not_hook() -> None:
    tr = simulate(scene(rg=(0.063, 0.066, 0.068), axis_1=(0.0, 1.0, 0.0), axis_2=(1.0, 0.0, 0.0)))
    assert tr.summary.hook_m == pytest.approx(0.0, abs=1e-12)


def test_mirrored_scene_hooks_the_other_way_exactly() -> None:
    base = paper_case(16)
    mirrored = json.loads(json.dumps(base))
    p = np.diag([1.0, -1.0, 1.0])
    ball = mirrored["ball"]
    ball["axis_1"] = list(p @ ball["axis_1"])
    ball["com_offset_m"] = list(p @ ball["com_offset_m"])
    wx, wy, wz = base["delivery"]["omega_radps"]
    mirrored["delivery"]["omega_radps"] = [-wx, wy, -wz]  # omega is a pseudovector
    mirrored["delivery"]["takeoff_angle_deg"] = -base["delivery"]["takeoff_angle_deg"]
    mirrored["delivery"]["position_m"] = [0.0, W - base["delivery"]["position_m"][1]]
    a = simulate(base).summary
    b = simulate(mirrored).summary
    assert a.hook_m is not None and b.hook_m is not None
    assert b.hook_m == pytest.approx(-a.hook_m, abs=1e-9)
    assert b.pocket_deg == pytest.approx(-a.pocket_deg, abs=1e-9)
    assert b.slide_m == pytest.approx(a.slide_m, abs=1e-9)


def test_summary_only_records_no_samples_but_the_same_summary() -> None:
    full = simulate(paper_case(12))
    summary_only = paper_case(12)
    summary_only["options"]["record"] = "summary"
    s = simulate(summary_only)
    assert s.n_samples == 0
    assert s.summary.hook_m == pytest.approx(full.summary.hook_m, abs=1e-9)


def test_fixed_rate_recording_samples_every_dt_and_every_event() -> None:
    d = paper_case(9)
    d["options"]["record"] = "rate"
    d["options"]["record_dt_s"] = 0.01
    tr = simulate(d)
    regular = tr.t_s[(tr.t_s > 0) & (np.abs(tr.t_s / 0.01 - np.round(tr.t_s / 0.01)) < 1e-6)]
    assert len(regular) == int(tr.summary.time_s / 0.01)
    for e in tr.events:
        assert np.any(tr.t_s == e.t_s)


def test_per_term_torques_sum_to_the_equation() -> None:
    d = paper_case(16)
    d["options"]["record_terms"] = True
    tr = simulate(d)
    names_lhs = ["I_o", "I_dev", "I_Delta_s", "I_DeltaDelta_s", "I_Roll", "I_Delta_r"]
    names_rhs = ["tau_fric", "tau_dev", "tau_Delta_s", "tau_DeltaDelta_s", "tau_Delta_r"]
    names_rhs.append("tau_DeltaDelta_r")
    lhs = sum(tr.torques_Nm[n] for n in names_lhs)
    rhs = sum(tr.torques_Nm[n] for n in names_rhs)
    np.testing.assert_allclose(lhs, rhs, atol=1e-12 * np.abs(rhs).max())
    sliding = tr.phase == 0
    assert np.all(tr.torques_Nm["tau_Delta_r"][sliding] == 0.0)
    assert np.any(tr.torques_Nm["tau_Delta_s"][sliding] != 0.0)
    assert np.all(tr.torques_Nm["tau_fric"][~sliding] == 0.0)


@pytest.mark.parametrize("case", [1, 5, 9, 16])
def test_paper_threshold_rule_same_in_summary_and_recorded_runs(case: int) -> None:
    # the threshold event is s . u_ref - thr (monotonic through the root), so large summary-only
    # steps cannot dip through it unseen; stick-slip (case 5) must not stall
    d = paper_case(case)
    d["options"]["slide_to_roll"] = "threshold"
    recorded = simulate(d).summary
    d["options"]["record"] = "summary"
    summary = simulate(d).summary
    assert summary.outcome == recorded.outcome == "pins"
    assert summary.slide_m == pytest.approx(recorded.slide_m, abs=1e-3)
    assert summary.hook_m == pytest.approx(recorded.hook_m, abs=1e-4)
