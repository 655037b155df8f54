"""The optional external terms (air drag, rolling resistance, Magnus lift, lane topography):
an independent Newton-Euler check of the right-hand side, the per-term decomposition, the
energy law along integrated runs, switching (off is bit-identical, run IDs unchanged) and the
shortcuts that must not be taken.

Independent check: per unit mass, with e (drag + rolling resistance + lift) applied at the
geometric center and g_h = (0, -g dz/dy, 0) at the center of mass,

    force:   a_com = F + e + g_h + (0, 0, -g)
    torque:  I alpha + w x (I w) = (r_Delta + R_con) x F + r_Delta x e   (about the center of mass)
    contact: a_cb_z = 0; sliding F_h = mu u F_z; rolling a_cb_h = (R_con x alpha)_h

nine linear equations in (alpha, F, a_cb), solved with numpy.linalg.solve; e and g_h are
computed here from their definitions (drag -k_D |v| v, rolling resistance -C_rr g v/|v|, lift
k_L C_L(S) |v|^2 (w x v)/|w x v|, the slope from scipy-free NumPy spline code in
``bowlrec.core.topography``, itself checked against a finite difference of the heights).
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bowlrec.archive.run_id import canonical_plan, run_id
from bowlrec.core.arguments import kernel_params, use_closed_form
from bowlrec.core.batch import pack_plans, run_batch
from bowlrec.core.closed_form import closed_form_kernel
from bowlrec.core.codes import LIFT_SAWICKI, PHASE_ROLL, PHASE_SLIDE, RECORD_RATE
from bowlrec.core.dynamics import (
    N_PAR,
    P_EXT,
    external_accel,
    pack_params,
    roll_accel,
    slide_accel,
)
from bowlrec.core.solver import kernel_call, solve
from bowlrec.core.terms import equation_terms, matvec
from bowlrec.core.topography import natural_spline, spline_slope
from bowlrec.spec import Scene

G = 9.81
R = 0.1085
REL_TOL = 1e-11  # as tests/test_physics_newton_euler.py (1e-12), one digit for the extra terms


def skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rot_matrix(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float) / np.linalg.norm(q)
    w, v = q[0], q[1:]
    s = np.linalg.norm(v)
    if s == 0.0:
        return np.eye(3)
    angle = 2.0 * np.arctan2(s, w)
    kx = skew(v / s)
    return np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * (kx @ kx)


def my_lift_cl(s: float) -> float:
    """Sawicki, Hubbard & Stronge (2003), Eq. (9)."""
    return 1.5 * s if s <= 0.1 else 0.09 + 0.6 * s


def my_external(y, kd, crr_g, kl, slope_fn):
    """(e, g_h) per unit mass from the definitions."""
    v = np.array([y[2], y[3], 0.0])
    w = y[8:11]
    sp = np.linalg.norm(v)
    e = -kd * sp * v - crr_g * v / sp
    if kl:
        c = np.cross(w, v)
        s = R * np.linalg.norm(c) / sp**2
        e = e + kl * my_lift_cl(s) * sp**2 * c / np.linalg.norm(c)
    gh = np.array([0.0, -G * slope_fn(y[1]), 0.0])
    return e, gh


def newton_euler(y, k2, rd_body, phase, e, gh, mu=0.0, u=(1.0, 0.0)):
    m = rot_matrix(y[4:8])
    inertia = m @ np.diag(k2) @ m.T
    rd = m @ rd_body
    w = y[8:11]
    rcon = np.array([0.0, 0.0, -R])
    rho = rd + rcon
    a = np.zeros((9, 9))
    b = np.zeros(9)
    ia, i_f, ic = slice(0, 3), slice(3, 6), slice(6, 9)
    # a_cb + r_Delta x alpha - F = g_vec + e + g_h + w x (w x r_Delta)
    a[0:3, ic] = np.eye(3)
    a[0:3, ia] = skew(rd)
    a[0:3, i_f] = -np.eye(3)
    b[0:3] = np.array([0.0, 0.0, -G]) + e + gh + np.cross(w, np.cross(w, rd))
    sc = 1.0 / R**2
    a[3:6, ia] = inertia * sc
    a[3:6, i_f] = -skew(rho) * sc
    b[3:6] = (-np.cross(w, inertia @ w) + np.cross(rd, e)) * sc
    a[6, 8] = 1.0
    if phase == PHASE_SLIDE:
        a[7, 3] = 1.0
        a[7, 5] = -mu * u[0]
        a[8, 4] = 1.0
        a[8, 5] = -mu * u[1]
    else:
        rc = skew(rcon)
        a[7, 6] = 1.0
        a[7, ia] = -rc[0]
        a[8, 7] = 1.0
        a[8, ia] = -rc[1]
    x = np.linalg.solve(a, b)
    return x[ia], x[i_f], x[ic]


def rel(a, b, floor):
    a = np.atleast_1d(np.asarray(a, dtype=float))
    b = np.atleast_1d(np.asarray(b, dtype=float))
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), floor))


PROFILE_Y = np.array([0.0, 0.2, 0.45, 0.6, 0.85, 1.0668])
PROFILE_Z = np.array([0.0, 1.2e-4, 1.9e-4, 1.8e-4, 9e-5, 0.0])  # a crown, ~0.2 mm


def test_spline_is_natural_and_smooth() -> None:
    """The natural spline: z'' = 0 at the ends, interpolates, slope continuous at the knots and
    equal to the finite difference of the interpolated heights; straight data: exact slope."""
    m = natural_spline(PROFILE_Y, PROFILE_Z)
    assert m[0] == 0.0 and m[-1] == 0.0
    # heights of the spline by integrating its slope from the first knot (Simpson, fine grid)
    yq = np.linspace(0.0, 1.0668, 20001)
    s = spline_slope(PROFILE_Y, PROFILE_Z, m, yq)
    z = np.concatenate([[0.0], np.cumsum(0.5 * (s[1:] + s[:-1]) * np.diff(yq))])
    at_knots = np.interp(PROFILE_Y, yq, z)
    np.testing.assert_allclose(at_knots, PROFILE_Z, atol=1e-11)
    eps = 1e-9
    left = spline_slope(PROFILE_Y, PROFILE_Z, m, PROFILE_Y[1:-1] - eps)
    right = spline_slope(PROFILE_Y, PROFILE_Z, m, PROFILE_Y[1:-1] + eps)
    np.testing.assert_allclose(left, right, atol=1e-11)
    line = 3e-4 * PROFILE_Y + 1e-3
    m2 = natural_spline(PROFILE_Y, line)
    np.testing.assert_allclose(m2, 0.0, atol=1e-15)
    np.testing.assert_allclose(spline_slope(PROFILE_Y, line, m2, yq), 3e-4, rtol=1e-12)


def _params(k2, rd_body, kd, crr_g, kl, slope, profile):
    prof = None
    if profile:
        prof = (PROFILE_Y, PROFILE_Z, natural_spline(PROFILE_Y, PROFILE_Z))
    return pack_params(
        R,
        G,
        k2,
        rd_body,
        drag_per_m=kd,
        rolling_resistance_mps2=crr_g,
        lift_per_m=kl,
        lift_model=LIFT_SAWICKI if kl else 0,
        cross_slope=slope,
        profile=prof,
    )


def _slope_fn(slope, profile):
    m = natural_spline(PROFILE_Y, PROFILE_Z)
    if not profile:
        return lambda yy: slope
    return lambda yy: slope + float(spline_slope(PROFILE_Y, PROFILE_Z, m, np.array([yy]))[0])


def _random_case(rng):
    base = rng.uniform(0.0555, 0.0715)
    k2 = (base + rng.uniform(0.0, 0.003, size=3)) ** 2
    d = rng.normal(size=3)
    rd_body = d / np.linalg.norm(d) * rng.uniform(0.0, 0.002)
    y = np.empty(11)
    y[0] = rng.uniform(0.0, 18.0)
    y[1] = rng.uniform(-0.1, 1.2)  # also beyond the profile's ends
    phi = rng.uniform(-0.5, 0.5)
    y[2:4] = rng.uniform(0.5, 10.0) * np.array([np.cos(phi), np.sin(phi)])
    q = rng.normal(size=4)
    y[4:8] = q / np.linalg.norm(q)
    d = rng.normal(size=3)
    y[8:11] = d / np.linalg.norm(d) * rng.uniform(0.0, 60.0)
    # scale the terms up (x 1-30) so that they are far above rounding in the comparison
    kd = rng.uniform(0.0, 0.1)
    crr_g = rng.uniform(0.0, 0.5)
    kl = rng.uniform(0.0, 0.1) * (rng.uniform() < 0.8)
    slope = rng.uniform(-1e-3, 1e-3)
    profile = bool(rng.uniform() < 0.5)
    return k2, rd_body, y, kd, crr_g, kl, slope, profile


@pytest.mark.parametrize("phase", [PHASE_SLIDE, PHASE_ROLL])
def test_rhs_matches_newton_euler_with_external_forces(phase: int) -> None:
    rng = np.random.default_rng(19 + phase)
    worst = np.zeros(3)
    for _ in range(1500):
        k2, rd_body, y, kd, crr_g, kl, slope, profile = _random_case(rng)
        if phase == PHASE_ROLL:
            y[2] = R * y[9]
            y[3] = -R * y[8]
            if math.hypot(y[2], y[3]) < 0.1:
                continue
        par = _params(k2, rd_body, kd, crr_g, kl, slope, profile)
        assert par[P_EXT] == 1.0
        e, gh = my_external(y, kd, crr_g, kl, _slope_fn(slope, profile))
        fe = external_accel(y, par)
        assert rel(fe[:3], e, 1e-6) < REL_TOL and rel(fe[3:], gh[:2], 1e-9) < REL_TOL
        if phase == PHASE_SLIDE:
            mu = rng.uniform(0.02, 0.3)
            ang = rng.uniform(0, 2 * np.pi)
            u = (math.cos(ang), math.sin(ang))
            al, f, acb = newton_euler(y, k2, rd_body, phase, e, gh, mu, u)
            r = slide_accel(y, par, mu, u[0], u[1])
            errs = (rel(r[2:5], al, 1e-3), rel(r[0:2], acb[:2], 1e-3), rel(r[5], f[2], 1e-3))
        else:
            al, f, acb = newton_euler(y, k2, rd_body, phase, e, gh)
            r = roll_accel(y, par)
            errs = (rel(r[2:5], al, 1e-3), rel(r[0:2], acb[:2], 1e-3), rel(r[5:8], f, 1e-3))
        worst = np.maximum(worst, errs)
        # the per-term decomposition: the paper's terms plus tau_ext give the same alpha, and
        # sum(I_k alpha) = sum(tau_k) with tau_ext included
        mats, taus, alpha = equation_terms(
            y,
            par,
            phase,
            mu if phase == PHASE_SLIDE else 0.0,
            *(u if phase == PHASE_SLIDE else (1.0, 0.0)),
        )
        assert taus.shape == (7, 3)
        assert rel(alpha, al, 1e-3) < REL_TOL
        lhs = sum(matvec(mats[j], alpha) for j in range(6))
        assert rel(lhs, taus.sum(axis=0), 1e-3 * R) < REL_TOL
    print(f"worst relative errors (alpha, a_cb, F): {worst}")
    assert np.all(worst < REL_TOL)


def test_uniform_ball_rolls_at_five_sevenths() -> None:
    """A uniform solid ball (k^2 = 2/5 R^2, no offset) under a horizontal force at its center,
    or on an incline, accelerates at e / (1 + k^2/R^2) = 5/7 e, 5/7 g slope."""
    k2 = np.full(3, 0.4 * R * R)
    y = np.zeros(11)
    y[4] = 1.0
    y[2] = 5.0
    y[9] = 5.0 / R
    par = _params(k2, np.zeros(3), 0.0, 0.3, 0.0, 0.0, False)
    assert roll_accel(y, par)[0] == pytest.approx(-5.0 / 7.0 * 0.3, rel=1e-14)
    par = _params(k2, np.zeros(3), 0.0, 0.0, 0.0, 1e-3, False)
    ax, ay = roll_accel(y, par)[:2]
    assert ax == 0.0 and ay == pytest.approx(-5.0 / 7.0 * G * 1e-3, rel=1e-14)


def test_off_means_nothing_new() -> None:
    """All terms zero: the flag is off and par is the flat-lane vector; the closed form, the
    batch's closed form and the run ID are those without the fields. Any term on: no closed
    form, and the batch kernel computes the term (equal to solve)."""
    plan = Scene.model_validate({"options": {"record": "summary"}}).resolve()
    par = kernel_params(plan)
    assert par[P_EXT] == 0.0 and par.shape == (N_PAR,)
    assert use_closed_form(plan)
    # air settings without drag or lift, and a zero topography, resolve to the same plan
    zero = Scene.model_validate(
        {
            "options": {"record": "summary"},
            "air": {"density_kg_m3": 1.0, "drag_coefficient": 0.3},
            "lane": {"topography": {"cross_slope": 0.0}, "rolling_resistance": 0.0},
        }
    ).resolve()
    assert canonical_plan(zero) == canonical_plan(plan)
    assert solve(zero).summary == solve(plan).summary
    for field, value in (
        ("drag_coefficient", 0.47),
        ("lift_model", LIFT_SAWICKI),
        ("rolling_resistance", 0.005),
        ("cross_slope", 5e-4),
        ("profile_y_m", PROFILE_Y),
    ):
        extra = {"profile_z_m": PROFILE_Z} if field == "profile_y_m" else {}
        on = dataclasses.replace(plan, **{field: value}, **extra)
        assert on.external_terms and not use_closed_form(on)
        assert kernel_call(on)[0] is not closed_form_kernel
        assert run_id(on) != run_id(plan)
        with pytest.raises(ValueError, match="flat lane"):
            kernel_call(on, method="closed_form")
        one = solve(on).summary
        packed = pack_plans([on, plan])
        assert not packed.flags[0, 0] and packed.flags[1, 0]  # closed form only for plan
        out = run_batch(packed, parallel=False).out
        assert out[0, 2] == one.x_end_m and out[0, 3] == one.y_end_m
        assert one != solve(plan).summary


def _fingerprint_variant() -> tuple[dict[str, Any], bool]:
    """The committed fingerprint of this physics version recorded on this platform (True), or else
    the first recorded one (False): see ``tools/kernel_fingerprint.py`` on what the bits of a
    result depend on besides the code."""
    from tools.kernel_fingerprint import platform

    fixture = json.loads(
        (Path(__file__).parent / "fixtures" / "kernel-fingerprint.json").read_text()
    )
    here = platform()
    for variant in fixture["variants"]:
        if variant["platform"] == here:
            return variant, True
    return fixture["variants"][0], False


def test_default_run_ids_unchanged() -> None:
    """Run IDs of scenes without the new fields, as computed before they existed (commit
    86ab6d9, physics frohlich2004-dp54-3: the same canonical plan under that version gives the
    same ID); and the canonical Plan has none of the new fields. A random delivery's plan goes
    through OpenBLAS (its frame is normalised with BLAS), so its ID is checked against the
    value recorded on this platform."""
    from bowlrec.paper import paper_scene
    from bowlrec.testing import random_plans

    older = "frohlich2004-dp54-3"
    assert run_id(Scene().resolve(), physics_version=older) == "6869b428ad6d059d14e5"
    assert run_id(paper_scene(5).resolve(), physics_version=older) == "e8833d95b85cd5d2acd8"
    variant, exact = _fingerprint_variant()
    if exact:
        assert run_id(random_plans(1)[0][1]) == variant["random_run_id"]
    else:
        warnings.warn(
            "no kernel fingerprint recorded for this platform: the random delivery's run ID "
            "is not compared (tools/kernel_fingerprint.py --subset records one)",
            stacklevel=1,
        )
    canon = canonical_plan(Scene().resolve())
    assert not {"drag_coefficient", "cross_slope", "profile_y_m", "lift_model"} & set(canon)


# ------------------------------------------------------------------ the energy law, all terms on


AXIS_1 = np.array([-0.47, 0.79, 0.25])
AXIS_2 = np.cross(AXIS_1, [0.3, -0.2, 1.0])
AXIS_2 /= np.linalg.norm(AXIS_2)


def _all_terms_scene(rtol: float) -> Scene:
    s15, c15 = math.sin(math.radians(15.0)), math.cos(math.radians(15.0))
    return Scene.model_validate(
        {
            "ball": {
                "rg_m": [0.062, 0.064, 0.066],
                "axis_1": list(AXIS_1),
                "axis_2": list(AXIS_2),
                "com_offset_m": [0.0003, 0.0005, -0.0003],
            },
            "lane": {
                "friction": {"kind": "constant", "mu": 0.12},
                "rolling_resistance": 0.01,
                "topography": {
                    "cross_slope": 2e-4,
                    "profile_m": np.column_stack([PROFILE_Y, PROFILE_Z]).tolist(),
                },
            },
            "air": {"drag": True, "magnus": True},
            "delivery": {
                "position_m": [0.0, 0.7],
                "speed_mps": 8.0,
                "takeoff_angle_deg": -1.0,
                "omega_radps": [-30 * c15 * 0.57, 30 * c15 * 0.82, 30 * s15],
            },
            "options": {"rtol": rtol, "record": "rate", "record_dt_s": 1e-4},
        }
    )


def _power(tr, plan) -> np.ndarray:
    """Per sample (W): friction at the slip -mu n |s| M, e . v_cb M, g_h . v_com M."""
    par = kernel_params(plan)
    mass = plan.mass_kg
    fric = -tr.mu * tr.normal_force_N * np.linalg.norm(tr.slip_mps, axis=1)
    fric[tr.phase == 1] = 0.0
    out = np.empty(tr.t_s.size)
    rd_body = plan.r_delta_body_m
    for k in range(tr.t_s.size):
        y = np.concatenate(
            [tr.position_m[k, :2], tr.velocity_mps[k, :2], tr.quaternion_wxyz[k], tr.omega_radps[k]]
        )
        ex, ey, ez, gx, gy = external_accel(y, par)
        rd = rot_matrix(y[4:8]) @ rd_body
        v_com = np.array([y[2], y[3], 0.0]) - np.cross(y[8:11], rd)
        out[k] = mass * (ex * y[2] + ey * y[3] + gx * v_com[0] + gy * v_com[1])
    return fric + out


def test_energy_law_all_terms() -> None:
    """E(t) - E(0) = int_0^t (friction power at the slip + e . v_cb + g_h . v_com) M dt' for a
    non-uniform ball with an offset and every term on (E: the flat-lane energy the samples
    report), over a whole run (sliding, the slide -> roll impulse's sample pair, rolling).

    The integral is the trapezoid rule on dense samples every 0.1 ms; its error is
    h^2/12 |P''| per unit time, ~1e2 h^2 = 1e-6 of the energy changed at most (P varies on the
    spin's time scale, |P''|/|P| ~ w^2 ~ 1e3 s^-2, as in tests/test_physics_energy.py);
    measured 3.9e-9. Tolerance 1e-6: the quadrature bound. Leaving out the external powers
    misses by 0.36 of the energy changed."""
    plan = _all_terms_scene(1e-11).resolve()
    assert plan.external_terms and plan.has_offset and not plan.scalar_inertia
    tr = solve(plan)
    assert tr.t_s[-1] > 1.0
    assert any(e.kind == "slide_to_roll" for e in tr.events)
    keep = np.concatenate([[True], np.diff(tr.t_s) > 0])
    # at events the sample is recorded twice (before and after): integrate piecewise
    t = tr.t_s
    e = tr.energy_J
    p = _power(tr, plan)
    work = np.zeros(t.size)
    for k in range(1, t.size):
        if not keep[k]:
            work[k] = work[k - 1]
            continue
        work[k] = work[k - 1] + 0.5 * (p[k] + p[k - 1]) * (t[k] - t[k - 1])
    changed = float(np.max(np.abs(e - e[0])))
    err = float(np.max(np.abs((e - e[0]) - work)) / changed)
    # the same balance without the external powers misses by far more
    fric = -tr.mu * tr.normal_force_N * np.linalg.norm(tr.slip_mps, axis=1)
    fric[tr.phase == 1] = 0.0
    w_f = np.concatenate([[0.0], np.cumsum(0.5 * (fric[1:] + fric[:-1]) * np.diff(t))])
    err_without = float(np.max(np.abs((e - e[0]) - w_f)) / changed)
    print(
        f"energy changed {changed:.4f} J; balance error {err:.2e}; without e, g_h {err_without:.2e}"
    )
    assert err < 1e-6
    assert err_without > 1e-2


def test_record_terms_has_tau_ext_only_when_on() -> None:
    plan = _all_terms_scene(1e-8).resolve()
    on = dataclasses.replace(plan, record_mode=RECORD_RATE, record_dt_s=0.05, record_terms=True)
    tr = solve(on)
    assert "tau_ext" in tr.torques_Nm
    assert np.abs(tr.torques_Nm["tau_ext"]).max() > 0.0
    flat = Scene.model_validate(
        {"options": {"record": "rate", "record_dt_s": 0.05, "record_terms": True}}
    )
    assert "tau_ext" not in solve(flat.resolve()).torques_Nm


def _close(got: dict[str, Any], want: dict[str, Any]) -> bool:
    """Summaries equal but for rounding: every count and outcome exactly, every float within
    1e-8 relative (1e-12 absolute near zero). Between platforms the bits differ by up to
    1e-9 relative, measured (tools/kernel_fingerprint.py); a change of the physics or of the
    step control moves metrics by orders of magnitude more, and counts with them."""
    if got.keys() != want.keys():
        return False
    for key, value in want.items():
        if isinstance(value, str) and value.lstrip("-").startswith("0x"):
            a, b = float.fromhex(got[key]), float.fromhex(value)
            if not math.isclose(a, b, rel_tol=1e-8, abs_tol=1e-12):
                return False
        elif got[key] != value:
            return False
    return True


def test_default_scenes_are_bit_identical_to_the_tree_without_the_terms() -> None:
    """Summaries (every metric, exact), right-hand-side counts and sample digests of the Table
    III cases, the bowler examples, the default scene and 20 random offset balls, in four record
    modes, equal those recorded for this physics version
    (``tests/fixtures/kernel-fingerprint.json``, extracted from ``tools/kernel_fingerprint.py``;
    the optional terms off) on this platform.
    On a platform with no recording, summaries are compared within rounding (:func:`_close`)
    and digests not at all, with a warning. A deliberate change of the default physics fails
    here: rewrite the fixture then (``tools/kernel_fingerprint.py --subset --replace``), with a
    note in the changelog."""
    from bowlrec.core.codes import RECORD_RATE, RECORD_STEPS
    from tools.kernel_fingerprint import _digest, _summary, deliveries

    expected, exact = _fingerprint_variant()
    if not exact:
        warnings.warn(
            "no kernel fingerprint recorded for this platform: summaries compared within "
            "rounding, sample digests not compared (tools/kernel_fingerprint.py --subset "
            "records one)",
            stacklevel=1,
        )
    plans = dict(deliveries())
    checked = 0
    for key, want in expected["summaries"].items():
        name, mode = key.split("|")
        plan = plans[name]
        if mode == "summary-auto":
            traj = solve(plan)
        elif mode == "summary-integrator":
            traj = solve(plan, method="integrator")
        elif mode == "steps":
            traj = solve(dataclasses.replace(plan, record_mode=RECORD_STEPS))
        else:
            traj = solve(dataclasses.replace(plan, record_mode=RECORD_RATE, record_dt_s=2e-3))
        if exact:
            assert _summary(traj) == want, key
            if key in expected["digests"]:
                assert _digest(traj) == expected["digests"][key], key
        else:
            assert _close(_summary(traj), want), key
        checked += 1
    assert checked == 236


def test_every_platforms_recording_agrees_within_rounding() -> None:
    """The fixture's recordings on other platforms agree with this platform's results
    within rounding (:func:`_close`), every count exact; and :func:`_close` refuses a count or
    a metric that moved."""
    from tools.kernel_fingerprint import _summary, deliveries, platform

    fixture = json.loads(
        (Path(__file__).parent / "fixtures" / "kernel-fingerprint.json").read_text()
    )
    plans = dict(deliveries())
    here = platform()
    others = [v for v in fixture["variants"] if v["platform"] != here]
    for variant in others:
        for key, want in variant["summaries"].items():
            name, mode = key.split("|")
            if mode == "summary-auto":
                assert _close(_summary(solve(plans[name])), want), key
    want = fixture["variants"][0]["summaries"]["case16-as_written|summary-auto"]
    assert _close(dict(want), want)
    assert not _close({**want, "n_rhs": want["n_rhs"] + 1}, want)
    moved = float.fromhex(want["hook_m"]) * (1 + 1e-7)
    assert not _close({**want, "hook_m": moved.hex()}, want)
