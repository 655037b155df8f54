"""Air drag and rolling resistance against closed forms, and the paper's estimate (footnote 15).

A uniform solid ball (k^2 = 2/5 R^2, no offset) going straight along x, per unit mass, with
k_D = C_D rho pi R^2 / (2 M):

* sliding without spin on constant friction mu: friction -mu g (n = g: drag is horizontal),
  dv/dt = -mu g - k_D v^2, so v(t) = sqrt(mu g / k_D) tan(theta0 - sqrt(mu g k_D) t),
  theta0 = atan(v0 sqrt(k_D / (mu g))), and x(t) = ln(cos(theta0 - a t) / cos theta0) / k_D;
* rolling with drag: the force at the center accelerates the rolling ball at
  e / (1 + k^2/R^2) = 5/7 e, so dv/dt = -c v^2, c = 5/7 k_D: v = v0 / (1 + c v0 t),
  x = ln(1 + c v0 t) / c;
* rolling with rolling resistance C_rr: v = v0 - 5/7 C_rr g t.

Tolerances: the runs use rtol 1e-12 and dense samples every ms; the integrator's global error
is then ~1e-11 relative and the dense output's ~1e-12 (measured: at most 7e-12 in x, 3e-15 in
v); the comparisons use 1e-9 relative (a wrong factor, e.g. 1 instead of 5/7, is ~0.1 off).
"""

from __future__ import annotations

import math

import numpy as np

from bowlrec.core.solver import solve
from bowlrec.spec import Scene

R = 0.1085
MASS = 6.8
G = 9.81
RG = math.sqrt(0.4) * R
RHO = 1.204
CD = 0.47
K_D = 0.5 * CD * RHO * math.pi * R**2 / MASS  # 1/m


def _scene(mu: float, omega_y: float, lane: dict | None = None, air: dict | None = None) -> Scene:
    return Scene.model_validate(
        {
            "ball": {"mass_kg": MASS, "radius_m": R, "rg_m": [RG, RG, RG]},
            "lane": {"friction": {"kind": "constant", "mu": mu}, **(lane or {})},
            "delivery": {"speed_mps": 8.0, "omega_radps": [0.0, omega_y, 0.0]},
            "air": air or {},
            "options": {"rtol": 1e-12, "record": "rate", "record_dt_s": 1e-3},
        }
    )


def test_sliding_with_drag_closed_form() -> None:
    mu = 0.04
    tr = solve(_scene(mu, 0.0, air={"drag": True}).resolve())
    assert np.all(tr.phase == 0)  # slides all the way (rolling would start after ~5.8 s)
    first_roll = tr.t_s.size
    t = tr.t_s
    v0 = 8.0
    a = math.sqrt(mu * G * K_D)
    th0 = math.atan(v0 * math.sqrt(K_D / (mu * G)))
    v = math.sqrt(mu * G / K_D) * np.tan(th0 - a * t)
    x = np.log(np.cos(th0 - a * t) / math.cos(th0)) / K_D
    err_v = np.max(np.abs(tr.velocity_mps[:first_roll, 0] - v) / v)
    err_x = np.max(np.abs(tr.position_m[1:first_roll, 0] - x[1:]) / x[1:])
    print(f"sliding {t[-1]:.3f} s; max rel error v {err_v:.2e}, x {err_x:.2e}")
    assert tr.summary.outcome == "pins" and t[-1] > 2.0
    assert err_v < 1e-9 and err_x < 1e-9
    # the same run without drag slides at -mu g: drag took a few % of the speed
    lost = (v0 - mu * G * t[-1]) - v[-1]
    assert 0.05 < lost < 0.5


def test_rolling_with_drag_closed_form() -> None:
    v0 = 8.0
    tr = solve(_scene(0.2, v0 / R, air={"drag": True}).resolve())
    assert np.all(tr.phase == 1)  # released rolling, never slips
    c = K_D / (1.0 + RG**2 / R**2)
    assert math.isclose(c, 5.0 / 7.0 * K_D, rel_tol=1e-15)
    t = tr.t_s
    v = v0 / (1.0 + c * v0 * t)
    x = np.log1p(c * v0 * t) / c
    err_v = np.max(np.abs(tr.velocity_mps[:, 0] - v) / v)
    err_x = np.max(np.abs(tr.position_m[1:, 0] - x[1:]) / x[1:])
    print(f"rolling to the pins in {t[-1]:.4f} s; max rel error v {err_v:.2e}, x {err_x:.2e}")
    assert err_v < 1e-9 and err_x < 1e-9


def test_rolling_resistance_closed_form() -> None:
    v0 = 8.0
    crr = 0.01
    tr = solve(_scene(0.2, v0 / R, lane={"rolling_resistance": crr}).resolve())
    assert np.all(tr.phase == 1)
    t = tr.t_s
    decel = crr * G / (1.0 + RG**2 / R**2)
    v = v0 - decel * t
    x = v0 * t - 0.5 * decel * t * t
    err_v = np.max(np.abs(tr.velocity_mps[:, 0] - v) / v)
    err_x = np.max(np.abs(tr.position_m[1:, 0] - x[1:]) / x[1:])
    print(f"max rel error v {err_v:.2e}, x {err_x:.2e}")
    assert err_v < 1e-9 and err_x < 1e-9


def test_paper_footnote_15_estimate() -> None:
    """Frohlich's footnote 15: drag is "not completely negligible ... sufficient to reduce a
    ball's velocity by a few percent over the length of a bowling lane". At 7-8 m/s the drag
    on a 21.7 cm ball is 0.5-0.7 N (~1 % of its weight); over the lane it takes 1-5 % of the
    speed of the default delivery."""
    area = math.pi * R**2
    forces = [0.5 * CD * RHO * area * v * v for v in (7.0, 8.0)]
    print(f"drag at 7, 8 m/s: {forces[0]:.3f}, {forces[1]:.3f} N")
    assert 0.5 <= forces[0] < forces[1] <= 1.0
    base = Scene.model_validate({"options": {"record": "summary"}})
    drag = base.model_copy(update={"air": base.air.model_copy(update={"drag": True})})
    s0 = solve(base.resolve()).summary
    s1 = solve(Scene.model_validate(drag.model_dump()).resolve()).summary
    assert s0.outcome == s1.outcome == "pins"
    loss = (s0.speed_end_mps - s1.speed_end_mps) / s0.speed_end_mps
    print(f"speed at the pins {s0.speed_end_mps:.4f} -> {s1.speed_end_mps:.4f} m/s ({loss:.2%})")
    assert 0.01 < loss < 0.05
