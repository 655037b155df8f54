"""Order of the integrator, measured on a smooth problem.

Problem: a non-uniform ball (rg 6.2/6.4/6.6 cm, general principal axes) with a 0.7 mm offset in
a general direction, sliding with side spin and tilt on constant mu 0.12 on a 3 m wide lane,
stopped at max_time_s = 1 s (outcome "max_time"): no event happens before (no zone, no
slide->roll: the slip stays > 0.9 m/s, far from the slip layer), so the right-hand side is smooth
(analytic) over the whole interval and the global error of an adaptive 5(4) run obeys

    error ~ C h^5 ~ C' n_steps^-5,        error ~ rtol (tolerance proportionality),

because the step control keeps the 4th-order error estimate ~ h^5 at rtol per step and the
propagated 5th-order solution (local extrapolation) has local error h^6, i.e. global h^5.

The final state is compared with a reference at rtol 1e-13 (its own error ~1e-13, more than
100x below the smallest error fitted here). The slip-layer threshold is fixed (it is derived from
rtol by default) so that every run integrates the same equations.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from bowlrec.core.codes import RECORD_RATE, RECORD_STEPS
from bowlrec.core.plan import Plan
from bowlrec.core.solver import solve
from bowlrec.spec import Options, Scene
from bowlrec.testing.rk4 import paper_scheme

T_END = 1.0
RTOLS = [1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 3e-11, 1e-11]
RTOL_REF = 1e-13

S35, C35 = math.sin(math.radians(35.0)), math.cos(math.radians(35.0))
S15, C15 = math.sin(math.radians(15.0)), math.cos(math.radians(15.0))


def smooth_plan() -> Plan:
    a1 = np.array([-S35 * C15, C35 * C15, 0.25])
    a2 = np.cross(a1, [0.3, -0.2, 1.0])
    off = np.array([0.4, 0.7, -0.3])
    scene = Scene.model_validate(
        {
            "ball": {
                "rg_m": [0.062, 0.064, 0.066],
                "axis_1": list(a1),
                "axis_2": list(a2 / np.linalg.norm(a2)),
                "com_offset_m": list(0.0007 * off / np.linalg.norm(off)),
            },
            "lane": {"width_m": 3.0, "friction": {"kind": "constant", "mu": 0.12}},
            "delivery": {
                "position_m": [0.0, 1.5],
                "speed_mps": 8.0,
                "takeoff_angle_deg": -1.0,
                "omega_radps": [-30 * C15 * S35, 30 * C15 * C35, 30 * S15],
            },
            "options": {"max_time_s": T_END},
        }
    )
    plan = scene.resolve()
    assert not plan.scalar_inertia and plan.has_offset and plan.constant_friction
    return dataclasses.replace(plan, slip_layer_mps=1e-8)


def _state(tr, i):  # type: ignore[no-untyped-def]
    """(x, y, vx, vy, q, omega) of sample i (or all samples when i is a slice)."""
    q = tr.quaternion_wxyz[i]
    return np.concatenate(
        [tr.position_m[i, :2], tr.velocity_mps[i, :2], q, tr.omega_radps[i]], axis=-1
    )


def _err(y: np.ndarray, y_ref: np.ndarray) -> float:
    """Max over components (and samples) of |y - y_ref| / (1 + |y_ref|): the integrator's own
    error scale (rtol (1 + |y|) per component)."""
    return float(np.max(np.abs(y - y_ref) / (1.0 + np.abs(y_ref))))


@pytest.fixture(scope="module")
def final_states():  # type: ignore[no-untyped-def]
    plan = smooth_plan()
    out = {}
    for rtol in [RTOL_REF, *RTOLS]:
        tr = solve(dataclasses.replace(plan, rtol=rtol, record_mode=RECORD_STEPS))
        out[rtol] = tr
    return out


def test_premise_smooth_problem_without_events(final_states) -> None:  # type: ignore[no-untyped-def]
    for rtol, tr in final_states.items():
        s = tr.summary
        assert s.outcome == "max_time", (rtol, s.outcome)
        assert [e.kind for e in tr.events] == ["max_time"], (rtol, tr.events)
        assert tr.t_s[-1] == T_END  # the last step is cut to land on max_time_s exactly
        assert np.all(tr.phase == 0)
        assert np.min(np.linalg.norm(tr.slip_mps, axis=1)) > 0.5
    # and the problem is not trivial: the offset and I_dev make the normal force wobble
    ref = final_states[RTOL_REF]
    n = ref.normal_force_N
    assert (n.max() - n.min()) / (6.8 * 9.81) > 1e-3


def _fit(x: list[float], y: list[float]) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def test_global_error_is_fifth_order_in_the_step_count(final_states) -> None:  # type: ignore[no-untyped-def]
    """Slope of log(error) vs log(n_steps) over rtol 1e-6..1e-11 (64..641 steps). A 5(4) pair with
    local extrapolation: -5 (measured -6.00; -6.04 on the loose half, -5.92 on the tight half: the
    error per unit rtol creeps from 3.3 to 0.4 over the range). Accepted [-6.5, -4], also for
    each half separately (the order must not degrade at tight tolerances); the error must fall
    monotonically."""
    y_ref = _state(final_states[RTOL_REF], -1)
    steps = [final_states[r].summary.n_steps for r in RTOLS]
    errs = [_err(_state(final_states[r], -1), y_ref) for r in RTOLS]
    table = [(r, n, f"{e:.2e}") for r, n, e in zip(RTOLS, steps, errs, strict=True)]
    print("rtol, n_steps, error:", table)
    slope = _fit(steps, errs)
    slope_lo = _fit(steps[:6], errs[:6])
    slope_hi = _fit(steps[5:], errs[5:])
    print(f"slope {slope:.3f} (loose half {slope_lo:.3f}, tight half {slope_hi:.3f})")
    assert -6.5 <= slope <= -4.0, slope
    assert -6.5 <= slope_lo <= -4.0, slope_lo
    assert -6.5 <= slope_hi <= -4.0, slope_hi
    assert all(b < a for a, b in zip(errs, errs[1:], strict=False)), errs
    assert all(b > a for a, b in zip(steps, steps[1:], strict=False)), steps
    # the reference is much tighter than anything fitted: its own error is ~1 x RTOL_REF (error /
    # rtol ~ 1 at tight tolerances), so it contaminates the smallest error by < 5%
    assert errs[-1] > 20 * RTOL_REF


def test_global_error_is_proportional_to_the_tolerance(final_states) -> None:  # type: ignore[no-untyped-def]
    """Tolerance proportionality: log(error) vs log(rtol) has slope 1 (measured 1.20), accepted
    [0.8, 1.3]; and the error stays within 100 rtol (measured 0.4-3.3 rtol)."""
    y_ref = _state(final_states[RTOL_REF], -1)
    errs = [_err(_state(final_states[r], -1), y_ref) for r in RTOLS]
    slope = _fit(RTOLS, errs)
    ratio = [e / r for e, r in zip(errs, RTOLS, strict=True)]
    print(f"error vs rtol slope {slope:.3f}; error / rtol: {[f'{x:.1f}' for x in ratio]}")
    assert 0.8 <= slope <= 1.3, slope
    assert max(ratio) <= 100.0, ratio


def test_dense_output_converges_at_the_same_rate() -> None:
    """The 4th-order continuous extension (used for record="rate" samples and for locating
    events) at the fixed times 0.01, 0.02, ... s: its error is the global error plus an
    interpolation error O(h^5), so the slope vs n_steps is again ~-5 (measured -5.84); accepted
    [-6.5, -3.5] (order >= 4 is what event location relies on)."""
    plan = smooth_plan()

    def run(rtol: float):  # type: ignore[no-untyped-def]
        return solve(
            dataclasses.replace(plan, rtol=rtol, record_mode=RECORD_RATE, record_dt_s=0.01)
        )

    ref = run(RTOL_REF)
    y_ref = _state(ref, slice(None))
    steps, errs = [], []
    for rtol in RTOLS:
        tr = run(rtol)
        np.testing.assert_array_equal(tr.t_s, ref.t_s)  # the same sample times
        steps.append(tr.summary.n_steps)
        errs.append(_err(_state(tr, slice(None)), y_ref))
    slope = _fit(steps, errs)
    print(f"dense output: slope {slope:.3f}; errors {[f'{e:.1e}' for e in errs]}")
    assert -6.5 <= slope <= -3.5, slope


def test_paper_fixed_step_rk4_is_fourth_order() -> None:
    """Fixed-step RK4 (the paper's scheme, :func:`bowlrec.testing.rk4.paper_scheme`; bowlrec's
    solver has no fixed-step method) on the same smooth problem: error of (x, y) at t = 1 s
    against bowlrec's reference at rtol 1e-13, dt = 2^-5..2^-10 s (32..1024 steps; powers of two
    so that the steps add up to exactly 1 s). Slope vs n_steps -4 (measured -4.01), accepted
    [-4.5, -3.5]."""
    names = set(Options.model_fields) | {f.name for f in dataclasses.fields(Plan)}
    if names & {"method", "integrator", "scheme", "fixed_step_s", "step_s", "dt_s", "h_s"}:
        pytest.skip("bowlrec grew a method option: test its order here")
    pytest.importorskip("scipy")  # numba's np.linalg.solve in the scheme's kernel
    plan = smooth_plan()
    ref = solve(dataclasses.replace(plan, rtol=RTOL_REF, record_mode=RECORD_STEPS)).summary
    steps, errs = [], []
    for k in range(5, 11):
        r = paper_scheme(plan, dt=2.0**-k)
        assert r["outcome"] == "max_time" and r["time_s"] == T_END, r
        steps.append(r["n_steps"])
        errs.append(
            max(abs(r["x_end_m"] - ref.x_end_m), abs(r["y_end_m"] - ref.y_end_m))
            / (1.0 + abs(ref.x_end_m))
        )
    slope = _fit(steps, errs)
    print(f"paper RK4: slope {slope:.3f}; steps {steps}; errors {[f'{e:.1e}' for e in errs]}")
    assert -4.5 <= slope <= -3.5, slope
