"""Independent check of the instantaneous dynamics against a direct Newton-Euler solve.

Derivation used here (lane frame, per unit mass M = 1; x toward the pins, y left, z up; the
geometric center at z = 0, R_con = (0, 0, -R); r_Delta points FROM the center of mass TO the
geometric center, so r_com = r_cb - r_Delta and d r_Delta/dt = w x r_Delta):

    force:       a_com = F + g_vec,   g_vec = (0, 0, -g)
                 a_com = a_cb - alpha x r_Delta - w x (w x r_Delta)
    torque:      I alpha + w x (I w) = (r_Delta + R_con) x F          (about the center of mass)
    contact:     a_cb_z = 0                                           (center stays at z = 0)
    sliding:     F_x = mu u_x F_z,  F_y = mu u_y F_z                  (Coulomb along the slip)
    rolling:     a_cb_xy = (R_con x alpha)_xy                         (d/dt of v_cb = R_con x w)

Nine linear equations in the nine unknowns (alpha, F, a_cb), solved with numpy.linalg.solve.
Nothing below uses the package's algebra (its 3x3 reductions, its term matrices, its signs).

The paper's separate terms, derived from the same equations (see Appendix A/B, whose OCR has
sign slips):

  Sliding: F = n mu_vec, mu_vec = (mu u_x, mu u_y, 1); the vertical force equation gives
      n = g + a_alpha + a_omega,  a_alpha = [r_Delta x alpha]_z,  a_omega = [(w x r_Delta) x w]_z.
  Torque: (I_o + I_dev) alpha + w x (I_dev w) = (r_Delta + R_con) x (g + a_alpha + a_omega) mu_vec,
  so  I_Delta^s alpha      = -a_alpha R_con  x mu_vec   (first order in r_Delta),
      I_DeltaDelta^s alpha = -a_alpha r_Delta x mu_vec  (second order),
      tau_fric = g R_con x mu_vec,  tau_dev = (I_dev w) x w,
      tau_Delta^s = g r_Delta x mu_vec + a_omega R_con x mu_vec,
      tau_DeltaDelta^s = a_omega r_Delta x mu_vec.
  As a matrix, with a_alpha = e_a . alpha, e_a = z x r_Delta = (-r_y, r_x, 0):
      I_Delta^s = R [[ mu_y r_y, -mu_y r_x, 0], [-mu_x r_y, mu_x r_x, 0], [0, 0, 0]]
  (the OCR'd Eq. (A9) prints +r_y mu_x in row 2: a sign slip), while Eq. (A10) for
  I_DeltaDelta^s is correct as printed.

  Rolling: F = g z + rho x alpha + (w x r_Delta) x w with rho = r_Delta + R_con (the OCR'd
  Eq. (B3) prints -g n: a sign slip; the torques of Eq. (B6) follow from +g n). Then
      I_Roll = diag(R^2, R^2, 0),  I_Delta^r = |rho|^2 1 - rho rho^T - I_Roll   (= Eq. (B5)),
      tau_Delta^r = g r_Delta x z + R [w^2 r_Delta x z + (w . r_Delta) z x w],
      tau_DeltaDelta^r = (w . r_Delta) w x r_Delta.
"""

from __future__ import annotations

import numpy as np
import pytest

from bowlrec.core.codes import PHASE_ROLL, PHASE_SLIDE
from bowlrec.core.dynamics import energy_per_mass, pack_params, rhs, roll_accel, slide_accel, slip
from bowlrec.core.terms import INERTIA_TERMS, TORQUE_TERMS, equation_terms

G = 9.81
N_STATES = 2000
Z = np.array([0.0, 0.0, 1.0])

# Tolerance: every quantity is compared as ||pkg - mine|| / max(||mine||, floor). Both sides are
# double-precision solutions of well-conditioned linear systems (condition numbers of the 9x9
# system after row scaling ~1e2-1e3), so the expected disagreement is ~1e-14; 1e-12 leaves two
# orders of magnitude of headroom while still catching any wrong sign or missing term (those
# are at least ~1e-6 relative: the smallest physical term, tau_DeltaDelta, is ~(r_Delta/R)^2).
REL_TOL = 1e-12
# Floors so that nearly vanishing vectors are compared absolutely. alpha is the solution of a
# system whose right-hand side is a sum of torques that can cancel (e.g. tau_dev against the
# offset torques); measuring the error relative to |alpha| alone would then amplify the rounding
# of the individual terms. The floor is the natural size of alpha at the state,
# alpha_scale = (g R + |w|^2 (|I_dev| + R |r_Delta|)) / I_ave: the torque sources per inertia.
FLOOR_ACC = 1e-3  # m/s^2 (g ~ 10 m/s^2), for accelerations and forces per unit mass
FLOOR_ALPHA = 1e-3  # rad/s^2 (typical |alpha| ~ 10-300 rad/s^2)


def alpha_scale(y, radius, k2, rd_body):
    w2 = float(y[8:11] @ y[8:11])
    return (G * radius + w2 * ((k2.max() - k2.min()) + radius * np.linalg.norm(rd_body))) / np.mean(
        k2
    )


# --------------------------------------------------------------------------- own helpers


def rot_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> lane) of a quaternion (w, x, y, z), built from the axis-angle
    (Rodrigues) form so it shares no code path with the package's quaternion formula."""
    q = np.asarray(q, dtype=float) / np.linalg.norm(q)
    w, v = q[0], q[1:]
    s = np.linalg.norm(v)
    if s == 0.0:
        return np.eye(3)
    angle = 2.0 * np.arctan2(s, w)
    k = v / s
    kx = skew(k)
    return np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * (kx @ kx)


def skew(a: np.ndarray) -> np.ndarray:
    """[a]_x with [a]_x b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def ball_world(y: np.ndarray, k2: np.ndarray, rd_body: np.ndarray):
    """World inertia per unit mass and r_Delta in the lane frame."""
    m = rot_matrix(y[4:8])
    return m @ np.diag(k2) @ m.T, m @ rd_body


def newton_euler(y, radius, k2, rd_body, phase, mu=0.0, u=(1.0, 0.0)):
    """Direct solve of the 9 Newton-Euler equations. Returns (alpha, F, a_cb), per unit mass."""
    inertia, rd = ball_world(y, k2, rd_body)
    w = y[8:11]
    rcon = np.array([0.0, 0.0, -radius])
    rho = rd + rcon
    a = np.zeros((9, 9))
    b = np.zeros(9)
    ia, i_f, ic = slice(0, 3), slice(3, 6), slice(6, 9)
    # force: a_cb + r_Delta x alpha - F = g_vec + w x (w x r_Delta)
    # (from a_com = a_cb - alpha x r_Delta - w x (w x r_Delta) = F + g_vec)
    a[0:3, ic] = np.eye(3)
    a[0:3, ia] = skew(rd)
    a[0:3, i_f] = -np.eye(3)
    b[0:3] = np.array([0.0, 0.0, -G]) + np.cross(w, np.cross(w, rd))
    # torque: I alpha - rho x F = -w x (I w); scaled by 1/R^2 so all rows are O(1)
    sc = 1.0 / radius**2
    a[3:6, ia] = inertia * sc
    a[3:6, i_f] = -skew(rho) * sc
    b[3:6] = -np.cross(w, inertia @ w) * sc
    # the geometric center stays in the plane z = 0
    a[6, 8] = 1.0
    if phase == PHASE_SLIDE:
        a[7, 3] = 1.0
        a[7, 5] = -mu * u[0]
        a[8, 4] = 1.0
        a[8, 5] = -mu * u[1]
    else:
        rc = skew(rcon)  # R_con x alpha
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


def random_ball(rng: np.random.Generator, radius: float = 0.1085):
    """rg in (5.5, 7.5) cm with a differential up to 3 mm; offset up to 2 mm, any direction."""
    base = rng.uniform(0.0555, 0.0715)
    rg = base + rng.uniform(0.0, 0.003, size=3)
    d = rng.normal(size=3)
    rd_body = d / np.linalg.norm(d) * rng.uniform(0.0, 0.002)
    return rg**2, rd_body


def random_state(rng: np.random.Generator) -> np.ndarray:
    y = np.empty(11)
    y[0:2] = rng.uniform(0.0, 1.0, size=2)
    phi = rng.uniform(0, 2 * np.pi)
    y[2:4] = rng.uniform(0.0, 10.0) * np.array([np.cos(phi), np.sin(phi)])
    q = rng.normal(size=4)
    y[4:8] = q / np.linalg.norm(q)
    d = rng.normal(size=3)
    y[8:11] = d / np.linalg.norm(d) * rng.uniform(0.0, 60.0)
    return y


def rolling_state(rng: np.random.Generator, radius: float) -> np.ndarray:
    y = random_state(rng)
    w = y[8:11]
    y[2] = radius * w[1]  # v_cb = R_con x w
    y[3] = -radius * w[0]
    return y


# --------------------------------------------------------------------------- closed-form terms


def closed_terms_slide(y, radius, k2, rd_body, mu, u, x):
    """Each paper term of Eq. (6) for a trial vector x (in place of alpha)."""
    inertia, rd = ball_world(y, k2, rd_body)
    w = y[8:11]
    rcon = np.array([0.0, 0.0, -radius])
    muv = np.array([mu * u[0], mu * u[1], 1.0])
    i_o = np.eye(3) * np.mean(k2)
    i_dev = inertia - i_o
    a_alpha = np.cross(rd, x)[2]
    a_omega = np.cross(np.cross(w, rd), w)[2]
    lhs = [
        i_o @ x,
        i_dev @ x,
        -a_alpha * np.cross(rcon, muv),
        -a_alpha * np.cross(rd, muv),
        np.zeros(3),
        np.zeros(3),
    ]
    rhs_ = [
        G * np.cross(rcon, muv),
        np.cross(i_dev @ w, w),
        G * np.cross(rd, muv) + a_omega * np.cross(rcon, muv),
        a_omega * np.cross(rd, muv),
        np.zeros(3),
        np.zeros(3),
    ]
    return lhs, rhs_, i_o, i_dev


def closed_terms_roll(y, radius, k2, rd_body, x):
    inertia, rd = ball_world(y, k2, rd_body)
    w = y[8:11]
    rcon = np.array([0.0, 0.0, -radius])
    rho = rd + rcon
    i_o = np.eye(3) * np.mean(k2)
    i_dev = inertia - i_o
    i_roll = np.diag([radius**2, radius**2, 0.0])
    rx, ry, rz = rd
    rr = radius
    # Eq. (B5) as printed
    i_delta_r = np.array(
        [
            [ry**2 + rz**2 - 2 * rz * rr, -rx * ry, -rx * rz + rx * rr],
            [-rx * ry, rx**2 + rz**2 - 2 * rz * rr, -ry * rz + ry * rr],
            [-rx * rz + rx * rr, -ry * rz + ry * rr, rx**2 + ry**2],
        ]
    )
    # and its vector form: rho x (rho x x) = rho (rho.x) - x |rho|^2  ->  I_Roll + I_Delta^r
    np.testing.assert_allclose(
        (i_roll + i_delta_r) @ x, -np.cross(rho, np.cross(rho, x)), rtol=1e-13, atol=1e-16
    )
    wr = w @ rd
    tau_dr = G * np.cross(rd, Z) + radius * ((w @ w) * np.cross(rd, Z) + wr * np.cross(Z, w))
    tau_ddr = wr * np.cross(w, rd)
    lhs = [i_o @ x, i_dev @ x, np.zeros(3), np.zeros(3), i_roll @ x, i_delta_r @ x]
    rhs_ = [np.zeros(3), np.cross(i_dev @ w, w), np.zeros(3), np.zeros(3), tau_dr, tau_ddr]
    return lhs, rhs_, i_o, i_dev, i_roll, i_delta_r


# --------------------------------------------------------------------------- tests


def test_term_names() -> None:
    assert INERTIA_TERMS == ("I_o", "I_dev", "I_Delta_s", "I_DeltaDelta_s", "I_Roll", "I_Delta_r")
    assert TORQUE_TERMS == (
        "tau_fric",
        "tau_dev",
        "tau_Delta_s",
        "tau_DeltaDelta_s",
        "tau_Delta_r",
        "tau_DeltaDelta_r",
    )


def test_sliding_matches_newton_euler() -> None:
    rng = np.random.default_rng(20040901)
    radius = 0.1085
    worst = dict.fromkeys(("acc", "alpha", "n", "terms_alpha", "balance", "balance_mine"), 0.0)
    worst_terms = np.zeros(12)
    for _ in range(N_STATES):
        k2, rd_body = random_ball(rng, radius)
        par = pack_params(radius, G, k2, rd_body)
        y = random_state(rng)
        mu = rng.uniform(0.0, 0.3)
        # the slip, by its definition s = R_con x w - v_cb
        s = np.cross([0.0, 0.0, -radius], y[8:11])[:2] - y[2:4]
        sx, sy = slip(y, par)
        assert rel((sx, sy), s, 1e-9) < 1e-15 * 10
        u = s / np.linalg.norm(s)
        alpha, f, acb = newton_euler(y, radius, k2, rd_body, PHASE_SLIDE, mu, u)
        ax, ay, alx, aly, alz, n = slide_accel(y, par, mu, u[0], u[1])
        fl = alpha_scale(y, radius, k2, rd_body)
        worst["acc"] = max(worst["acc"], rel((ax, ay), acb[:2], FLOOR_ACC))
        worst["alpha"] = max(worst["alpha"], rel((alx, aly, alz), alpha, fl))
        # n is the normal force per unit mass: F_z / M
        worst["n"] = max(worst["n"], abs(n - f[2]) / G)
        assert abs(acb[2]) < 1e-12 * G

        mats, taus, al = equation_terms(y, par, PHASE_SLIDE, mu, u[0], u[1])
        worst["terms_alpha"] = max(worst["terms_alpha"], rel(al, alpha, fl))
        # sum_k I_k alpha == sum_k tau_k, relative to the size of the individual terms
        lhs = sum(mats[k] @ al for k in range(6))
        lhs_mine = sum(mats[k] @ alpha for k in range(6))
        rhs_ = taus.sum(axis=0)
        scale = max(
            max(np.linalg.norm(mats[k] @ al) for k in range(6)),
            max(np.linalg.norm(t) for t in taus),
            np.mean(k2) * fl,
        )
        worst["balance"] = max(worst["balance"], np.linalg.norm(lhs - rhs_) / scale)
        worst["balance_mine"] = max(worst["balance_mine"], np.linalg.norm(lhs_mine - rhs_) / scale)

        # each term against its closed form; x = a random trial vector so the matrices are
        # checked as linear maps, not only along the solution alpha
        x = rng.normal(size=3) * 100.0
        c_lhs, c_rhs, i_o, i_dev = closed_terms_slide(y, radius, k2, rd_body, mu, u, x)
        np.testing.assert_allclose(mats[0], i_o, rtol=1e-14, atol=0)
        np.testing.assert_allclose(mats[1], i_dev, rtol=0, atol=1e-13 * np.mean(k2))
        for k in range(6):
            ref = c_lhs[k]
            worst_terms[k] = max(
                worst_terms[k],
                np.linalg.norm(mats[k] @ x - ref) / (np.linalg.norm(x) * np.mean(k2)),
            )
            ref = c_rhs[k]
            worst_terms[6 + k] = max(
                worst_terms[6 + k], np.linalg.norm(taus[k] - ref) / (G * radius)
            )
        # the explicitly derived matrices (sign of row 2 differs from the OCR'd Eq. (A9))
        rx, ry, rz = ball_world(y, k2, rd_body)[1]
        mx, my = mu * u[0], mu * u[1]
        i_ds = radius * np.array([[my * ry, -my * rx, 0], [-mx * ry, mx * rx, 0], [0, 0, 0]])
        i_dds = np.array(  # Eq. (A10) as printed
            [
                [ry * (ry - rz * my), -rx * (ry - rz * my), 0],
                [ry * (rz * mx - rx), -rx * (rz * mx - rx), 0],
                [ry * (rx * my - ry * mx), -rx * (rx * my - ry * mx), 0],
            ]
        )
        np.testing.assert_allclose(mats[2], i_ds, rtol=0, atol=1e-18)
        np.testing.assert_allclose(mats[3], i_dds, rtol=0, atol=1e-18)
        assert np.all(mats[4] == 0.0) and np.all(mats[5] == 0.0)
        assert np.all(taus[4] == 0.0) and np.all(taus[5] == 0.0)

    print("sliding worst:", worst, "terms:", worst_terms)
    for key, val in worst.items():
        assert val < REL_TOL, (key, val)
    # terms: relative to the natural scales k^2 |x| (inertia) and g R (torque per mass)
    assert np.all(worst_terms < 1e-13), worst_terms


def test_rolling_matches_newton_euler() -> None:
    rng = np.random.default_rng(72)
    radius = 0.1085
    worst = dict.fromkeys(("acc", "alpha", "f", "n", "terms_alpha", "balance"), 0.0)
    worst_terms = np.zeros(12)
    for _ in range(N_STATES):
        k2, rd_body = random_ball(rng, radius)
        par = pack_params(radius, G, k2, rd_body)
        y = rolling_state(rng, radius)
        alpha, f, acb = newton_euler(y, radius, k2, rd_body, PHASE_ROLL)
        ax, ay, alx, aly, alz, fx, fy, n = roll_accel(y, par)
        fl = alpha_scale(y, radius, k2, rd_body)
        worst["acc"] = max(worst["acc"], rel((ax, ay), acb[:2], radius * fl))
        worst["alpha"] = max(worst["alpha"], rel((alx, aly, alz), alpha, fl))
        worst["f"] = max(worst["f"], rel((fx, fy, n), f, FLOOR_ACC))
        worst["n"] = max(worst["n"], abs(n - f[2]) / G)

        mu = rng.uniform(0.0, 0.3)  # ignored while rolling
        mats, taus, al = equation_terms(y, par, PHASE_ROLL, mu, 1.0, 0.0)
        worst["terms_alpha"] = max(worst["terms_alpha"], rel(al, alpha, fl))
        lhs = sum(mats[k] @ alpha for k in range(6))
        rhs_ = taus.sum(axis=0)
        scale = max(
            max(np.linalg.norm(mats[k] @ alpha) for k in range(6)),
            max(np.linalg.norm(t) for t in taus),
            np.mean(k2) * fl,
        )
        worst["balance"] = max(worst["balance"], np.linalg.norm(lhs - rhs_) / scale)

        x = rng.normal(size=3) * 100.0
        c_lhs, c_rhs, i_o, i_dev, i_roll, i_dr = closed_terms_roll(y, radius, k2, rd_body, x)
        np.testing.assert_allclose(mats[0], i_o, rtol=1e-14, atol=0)
        np.testing.assert_allclose(mats[1], i_dev, rtol=0, atol=1e-13 * np.mean(k2))
        np.testing.assert_array_equal(mats[4], i_roll)
        np.testing.assert_allclose(mats[5], i_dr, rtol=0, atol=1e-13 * radius**2)
        for k in range(6):
            worst_terms[k] = max(
                worst_terms[k],
                np.linalg.norm(mats[k] @ x - c_lhs[k]) / (np.linalg.norm(x) * np.mean(k2)),
            )
            worst_terms[6 + k] = max(
                worst_terms[6 + k], np.linalg.norm(taus[k] - c_rhs[k]) / (G * radius)
            )
        for k in (2, 3):
            assert np.all(mats[k] == 0.0)
        for k in (0, 2, 3):
            assert np.all(taus[k] == 0.0)

    print("rolling worst:", worst, "terms:", worst_terms)
    for key, val in worst.items():
        assert val < REL_TOL, (key, val)
    assert np.all(worst_terms < 1e-13), worst_terms


@pytest.mark.parametrize("scalar", [True, False])
def test_normal_force_is_g_without_offset(scalar: bool) -> None:
    """With r_Delta = 0 the center of mass never moves vertically: n = g exactly (sliding and
    rolling), also for a non-scalar inertia tensor."""
    rng = np.random.default_rng(5)
    radius = 0.1085
    k2 = np.full(3, 0.067**2) if scalar else np.array([0.062, 0.064, 0.066]) ** 2
    par = pack_params(radius, G, k2, np.zeros(3))
    for _ in range(200):
        y = random_state(rng)
        mu = rng.uniform(0.0, 0.3)
        sx, sy = slip(y, par)
        s = np.hypot(sx, sy)
        assert slide_accel(y, par, mu, sx / s, sy / s)[5] == G
        yr = rolling_state(rng, radius)
        assert roll_accel(yr, par)[7] == G
        # and the direct solve agrees (F_z = M g)
        _, f, _ = newton_euler(yr, radius, k2, np.zeros(3), PHASE_ROLL)
        assert abs(f[2] - G) < 1e-13 * G


def test_offset_normal_force_closed_form() -> None:
    """n = g + a_alpha + a_omega (Eq. (A6), sliding) with the package's own alpha; and for a
    spinning ball at rest with no other motion the centripetal term alone: a_omega."""
    rng = np.random.default_rng(11)
    radius = 0.1085
    for _ in range(200):
        k2, rd_body = random_ball(rng, radius)
        par = pack_params(radius, G, k2, rd_body)
        y = random_state(rng)
        mu = rng.uniform(0.0, 0.3)
        sx, sy = slip(y, par)
        s = np.hypot(sx, sy)
        ax, ay, alx, aly, alz, n = slide_accel(y, par, mu, sx / s, sy / s)
        _, rd = ball_world(y, k2, rd_body)
        w = y[8:11]
        a_alpha = np.cross(rd, [alx, aly, alz])[2]
        a_omega = np.cross(np.cross(w, rd), w)[2]
        assert abs(n - (G + a_alpha + a_omega)) < 1e-13 * G


def test_rhs_and_energy_consistent() -> None:
    """rhs(): velocities, accelerations (from slide/roll_accel along the slip), the quaternion
    kinematics dq/dt = 1/2 (0, w) q (checked against a finite rotation), and the energy
    1/2 v_com^2 + 1/2 w.I w + g z_com with z_com = -r_Delta,z."""
    rng = np.random.default_rng(3)
    radius = 0.1085
    dy = np.empty(11)
    for _ in range(200):
        k2, rd_body = random_ball(rng, radius)
        par = pack_params(radius, G, k2, rd_body)
        y = random_state(rng)
        mu = rng.uniform(0.01, 0.3)
        sx, sy = slip(y, par)
        s = np.hypot(sx, sy)
        n, margin, ux, uy = rhs(y, par, PHASE_SLIDE, mu, sx / s, sy / s, True, dy)
        assert abs(ux - sx / s) < 1e-15 and abs(uy - sy / s) < 1e-15
        assert abs(margin - s) < 1e-14 * s
        alpha, f, acb = newton_euler(y, radius, k2, rd_body, PHASE_SLIDE, mu, (ux, uy))
        np.testing.assert_array_equal(dy[0:2], y[2:4])
        assert rel(dy[2:4], acb[:2], FLOOR_ACC) < REL_TOL
        assert rel(dy[8:11], alpha, FLOOR_ALPHA) < REL_TOL
        # dq/dt: compare R(q(t+h)) with exp(h [w]x) R(q) to first order via central differences
        h = 1e-6
        m0 = rot_matrix(y[4:8])
        mdot_num = (rot_matrix(y[4:8] + h * dy[4:8]) - rot_matrix(y[4:8] - h * dy[4:8])) / (2 * h)
        np.testing.assert_allclose(mdot_num, skew(y[8:11]) @ m0, rtol=0, atol=1e-6)
        # energy
        inertia, rd = ball_world(y, k2, rd_body)
        w = y[8:11]
        v_com = np.array([y[2], y[3], 0.0]) - np.cross(w, rd)
        e = 0.5 * v_com @ v_com + 0.5 * w @ inertia @ w - G * rd[2]
        assert abs(energy_per_mass(y, par) - e) < 1e-13 * e
        # rolling: margin = mu n - |f|
        yr = rolling_state(rng, radius)
        n, margin, ux, uy = rhs(yr, par, PHASE_ROLL, mu, 1.0, 0.0, True, dy)
        _, f, acb = newton_euler(yr, radius, k2, rd_body, PHASE_ROLL)
        assert abs(margin - (mu * f[2] - np.hypot(f[0], f[1]))) < 1e-12 * G
        assert ux == 0.0 and uy == 0.0


def test_sensitivity_printed_a9_sign_slip() -> None:
    """The comparison is sensitive enough to see a single sign slip: the OCR'd Eq. (A9) (row 2
    printed as R (r_y mu_x, r_x mu_x, 0)) gives an alpha that disagrees with the direct
    Newton-Euler solve by many orders of magnitude more than REL_TOL, while the derived matrix
    (row 2 = R (-r_y mu_x, r_x mu_x, 0)) agrees."""
    rng = np.random.default_rng(9)
    radius = 0.1085
    k2 = np.array([0.062, 0.064, 0.066]) ** 2
    rd_body = np.array([0.0012, -0.0009, 0.0011])
    par = pack_params(radius, G, k2, rd_body)
    y = random_state(rng)
    y[2:4] = (8.0, 0.5)
    mu = 0.2
    sx, sy = slip(y, par)
    u = np.array([sx, sy]) / np.hypot(sx, sy)
    alpha, _, _ = newton_euler(y, radius, k2, rd_body, PHASE_SLIDE, mu, u)
    mats, taus, al = equation_terms(y, par, PHASE_SLIDE, mu, u[0], u[1])
    rx, ry, _ = ball_world(y, k2, rd_body)[1]
    mx, my = mu * u
    printed = radius * np.array([[ry * my, -rx * my, 0], [ry * mx, rx * mx, 0], [0, 0, 0]])
    a_printed = mats[0] + mats[1] + printed + mats[3]
    alpha_printed = np.linalg.solve(a_printed, taus.sum(axis=0))
    fl = alpha_scale(y, radius, k2, rd_body)
    assert rel(al, alpha, fl) < REL_TOL
    assert rel(alpha_printed, alpha, fl) > 1e-6
