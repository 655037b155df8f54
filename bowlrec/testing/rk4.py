"""The paper's scheme: fixed-step classical RK4 with the 1 cm/s slide -> roll rule.

A reference solver for tests and benchmarks, independent of bowlrec's adaptive integrator and
its event location: :func:`paper_scheme` integrates a :class:`~bowlrec.core.plan.Plan` with a
fixed step on bowlrec's compiled right-hand side ``rhs(y, par, phase, mu, ux_ref, uy_ref,
orient, dy)`` (``par = kernel_params(plan)``; only PHASE_SLIDE and PHASE_ROLL are used), as a
numba kernel. Its result is a dict with the keys

    outcome ("pins", "gutter", "stopped", "airborne", "max_time"), slide_m (x where rolling
    first starts, None if never), hook_m, pocket_deg (None unless the ball reaches the pins),
    time_s, x_end_m, y_end_m, n_rhs (right-hand-side evaluations), n_steps

(:func:`result_dict`: the same dict for other methods; :func:`summary_plan`: a plan switched to
summary-only recording; :func:`remove_slip_impulse`: the contact impulse that zeroes the slip,
as bowlrec applies it when rolling starts).

The kernels use ``np.linalg.solve``, which numba links from scipy's LAPACK: this module needs
scipy (in the ``test`` and ``bench`` extras), bowlrec itself does not.

The kernels are cached on disk by numba (``bowlrec/testing/__pycache__``). numba keys a cached
function on its own source file only, and these kernels compile bowlrec's dynamics into
themselves: their entries are dropped when this module or a ``bowlrec`` module it imports
(transitively: ``bowlrec.core.arguments`` and what it imports) differs from the one they were built
from, by the rule of ``bowlrec.core._kernel_cache`` for the core's own kernels.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit

from bowlrec.core._kernel_cache import drop_stale_kernels
from bowlrec.core.arguments import initial_state, kernel_params, needs_orientation
from bowlrec.core.codes import (
    OUTCOMES,
    PHASE_ROLL,
    PHASE_SLIDE,
    RECORD_SUMMARY,
    STATUS_AIRBORNE,
    STATUS_GUTTER,
    STATUS_MAX_TIME,
    STATUS_PINS,
    STATUS_RUNNING,
    STATUS_STOPPED,
)
from bowlrec.core.dynamics import P_R, P_SLAYER, ball_frame, rhs, roll_accel, slip
from bowlrec.core.plan import Plan

__all__ = ["paper_scheme", "remove_slip_impulse", "result_dict", "summary_plan"]


#: what the check of this directory's numba cache did at import (before any kernel loads)
CACHE_CHECK = drop_stale_kernels(Path(__file__).parent)


def result_dict(
    plan: Plan, outcome: str, slide: float | None, t: float, y: np.ndarray, n_rhs: int, **extra: Any
) -> dict[str, Any]:
    """The common result dict (Table III definitions, all taken at the final state)."""
    hook = pocket = None
    if outcome == "pins":
        x0, y0 = (float(v) for v in plan.position0_m)
        vx0, vy0 = (float(v) for v in plan.velocity0_mps)
        hook = float(y[1] - (y0 + (y[0] - x0) * vy0 / vx0))
        pocket = math.degrees(math.atan2(y[3], y[2]))
    out: dict[str, Any] = {
        "outcome": outcome,
        "slide_m": None if slide is None else float(slide),
        "hook_m": hook,
        "pocket_deg": pocket,
        "time_s": float(t),
        "x_end_m": float(y[0]),
        "y_end_m": float(y[1]),
        "n_rhs": int(n_rhs),
    }
    out.update(extra)
    return out


def summary_plan(plan: Plan, rtol: float | None = None, s_layer: float | None = None) -> Plan:
    """``plan`` recording the summary only, with ``rtol`` and the slip layer ``s_layer`` (m/s)
    replaced where given."""
    changes: dict[str, Any] = {"record_mode": RECORD_SUMMARY, "record_terms": False}
    if rtol is not None:
        changes["rtol"] = float(rtol)
    if s_layer is not None:
        changes["slip_layer_mps"] = float(s_layer)
    return dataclasses.replace(plan, **changes)


@njit(cache=True, error_model="numpy")
def _impulse_response(y, par, jx, jy):  # type: ignore[no-untyped-def]
    """Changes (dvx, dvy, dwx, dwy, dwz) of a horizontal impulse (jx, jy) per unit mass at the
    contact point: dw = I^-1 (rho x J) with rho = r_Delta + R_con, dv_cb = J + dw x r_Delta."""
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    pz = rdz - par[P_R]
    lx = rdy * 0.0 - pz * jy
    ly = pz * jx - rdx * 0.0
    lz = rdx * jy - rdy * jx
    a = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    dw = np.linalg.solve(a, np.array([lx, ly, lz]))
    dvx = jx + dw[1] * rdz - dw[2] * rdy
    dvy = jy + dw[2] * rdx - dw[0] * rdz
    return dvx, dvy, dw[0], dw[1], dw[2]


@njit(cache=True, error_model="numpy")
def remove_slip_impulse(y, par):  # type: ignore[no-untyped-def]
    """Make the slip exactly zero with a contact impulse (like a short burst of friction)."""
    R = par[P_R]
    sx = R * y[9] - y[2]
    sy = -R * y[8] - y[3]
    m = np.empty((2, 2))
    for j in range(2):
        dvx, dvy, dwx, dwy, _ = _impulse_response(y, par, 1.0 - j, float(j))
        m[0, j] = R * dwy - dvx
        m[1, j] = -R * dwx - dvy
    jv = np.linalg.solve(m, np.array([-sx, -sy]))
    dvx, dvy, dwx, dwy, dwz = _impulse_response(y, par, jv[0], jv[1])
    y[2] += dvx
    y[3] += dvy
    y[8] += dwx
    y[9] += dwy
    y[10] += dwz


@njit(cache=True, error_model="numpy")
def _reserve(y, par, mu):  # type: ignore[no-untyped-def]
    r = roll_accel(y, par)
    fx = r[5]
    fy = r[6]
    fn = math.sqrt(fx * fx + fy * fy)
    if fn > 0.0:
        return mu * r[7] - fn, fx / fn, fy / fn
    return mu * r[7], 1.0, 0.0


@njit(cache=True, error_model="numpy")
def _paper_kernel(par, y0, x_edges, y_edges, mu_grid, lane_length, lane_width, dt, threshold,
                  max_time, orient, snap_impulse):  # type: ignore[no-untyped-def]  # fmt: skip
    """Fixed-step classical RK4; returns (status, t_end, y_end, slide_x, n_rhs, n_steps).

    slide_x is NaN if the ball never rolls."""
    n = y0.shape[0]
    R = par[P_R]
    s_layer = par[P_SLAYER]
    y = y0.copy()
    ynew = np.empty(n)
    ytmp = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    t = 0.0
    n_rhs = 0
    n_steps = 0
    slide_x = math.nan
    status = STATUS_RUNNING

    ix = np.searchsorted(x_edges, y[0], side="right")
    iy = np.searchsorted(y_edges, y[1], side="right")
    mu = mu_grid[ix, iy]
    sx, sy = slip(y, par)
    s0 = math.sqrt(sx * sx + sy * sy)
    phase = PHASE_SLIDE
    uxr = 1.0
    uyr = 0.0
    if s0 > 0.0:
        uxr = sx / s0
        uyr = sy / s0
    else:
        res, fx, fy = _reserve(y, par, mu)
        if res >= 0.0:
            phase = PHASE_ROLL
            slide_x = y[0]
        else:
            uxr = fx
            uyr = fy

    while True:
        if t >= max_time:
            status = STATUS_MAX_TIME
            break
        # friction under the ball at the start of the step
        ix = np.searchsorted(x_edges, y[0], side="right")
        iy = np.searchsorted(y_edges, y[1], side="right")
        mu = mu_grid[ix, iy]
        if phase == PHASE_SLIDE:
            sx, sy = slip(y, par)
            s0 = math.sqrt(sx * sx + sy * sy)
            if s0 > 0.5 * s_layer:  # below, rhs uses the slaved direction warm-started at u_ref
                uxr = sx / s0
                uyr = sy / s0
        r1 = rhs(y, par, phase, mu, uxr, uyr, orient, k1)
        n_rhs += 1
        if r1[0] <= 0.0:
            status = STATUS_AIRBORNE
            break
        for i in range(n):
            ytmp[i] = y[i] + 0.5 * dt * k1[i]
        rhs(ytmp, par, phase, mu, uxr, uyr, orient, k2)
        for i in range(n):
            ytmp[i] = y[i] + 0.5 * dt * k2[i]
        rhs(ytmp, par, phase, mu, uxr, uyr, orient, k3)
        for i in range(n):
            ytmp[i] = y[i] + dt * k3[i]
        rhs(ytmp, par, phase, mu, uxr, uyr, orient, k4)
        n_rhs += 3
        n_steps += 1
        for i in range(n):
            ynew[i] = y[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if orient:
            qn = math.sqrt(ynew[4] ** 2 + ynew[5] ** 2 + ynew[6] ** 2 + ynew[7] ** 2)
            for i in range(4, 8):
                ynew[i] /= qn
        # pins, gutters, stop: linear interpolation between the two step ends
        theta = 2.0
        st = STATUS_RUNNING
        if ynew[0] >= lane_length:
            th = (lane_length - y[0]) / (ynew[0] - y[0])
            if th < theta:
                theta = th
                st = STATUS_PINS
        if ynew[1] <= 0.0:
            th = (0.0 - y[1]) / (ynew[1] - y[1])
            if th < theta:
                theta = th
                st = STATUS_GUTTER
        if ynew[1] >= lane_width:
            th = (lane_width - y[1]) / (ynew[1] - y[1])
            if th < theta:
                theta = th
                st = STATUS_GUTTER
        if ynew[2] <= 0.0:
            th = (0.0 - y[2]) / (ynew[2] - y[2])
            if th < theta:
                theta = th
                st = STATUS_STOPPED
        if st != STATUS_RUNNING:
            for i in range(n):
                y[i] = y[i] + theta * (ynew[i] - y[i])
            t = t + theta * dt
            status = st
            break
        for i in range(n):
            y[i] = ynew[i]
        t += dt
        # phase changes at the step end (mu under the new position)
        ix = np.searchsorted(x_edges, y[0], side="right")
        iy = np.searchsorted(y_edges, y[1], side="right")
        mu = mu_grid[ix, iy]
        if phase == PHASE_SLIDE:
            sx, sy = slip(y, par)
            if math.sqrt(sx * sx + sy * sy) < threshold:
                ytry = y.copy()
                if snap_impulse:
                    remove_slip_impulse(ytry, par)
                else:
                    ytry[2] = R * y[9]
                    ytry[3] = -R * y[8]
                res, fx, fy = _reserve(ytry, par, mu)
                if res >= 0.0:
                    for i in range(n):
                        y[i] = ytry[i]
                    phase = PHASE_ROLL
                    if slide_x != slide_x:
                        slide_x = y[0]
        else:
            res, fx, fy = _reserve(y, par, mu)
            if res < 0.0:
                phase = PHASE_SLIDE
                uxr = fx
                uyr = fy
    return status, t, y, slide_x, n_rhs, n_steps


def paper_scheme(
    plan: Plan,
    dt: float = 1e-3,
    threshold: float = 0.01,
    *,
    snap: str = "velocity",
    s_layer: float = 1e-5,
) -> dict[str, Any]:
    """The paper's scheme: classical RK4 with a fixed step ``dt`` (s) on the same ``rhs``.

    mu is looked up at the start of each step. At a step end a sliding ball with
    |slip| < ``threshold`` (m/s) starts rolling, provided the rolling ball's friction reserve is
    >= 0 there (else it keeps sliding: a ball at the edge of the friction cone would otherwise
    flip phase at every step); a rolling ball whose friction reserve is negative starts sliding
    (u_ref = the direction of the friction it needed). Pins, gutters and vx = 0 are taken by
    linear interpolation between the two step ends that bracket them.

    ``snap``: how the remaining slip (< threshold) is removed when rolling starts:
    ``"velocity"`` sets v = R_con x w (omega unchanged; this changes the momentum by up to
    threshold and moves hook and pocket by mm / 0.01 deg); ``"impulse"`` applies the contact
    impulse that zeroes the slip (what bowlrec does; equivalent to the friction of the
    remaining slide when the slip direction is steady). ``s_layer`` (m/s): slip speed below which
    ``rhs`` lets friction act along the slaved direction (bowlrec's default; the slip is then
    defined at s = 0 after a rolling ball starts to slip).
    """
    if snap not in ("velocity", "impulse"):
        raise ValueError(f"snap = {snap!r} must be 'velocity' or 'impulse'")
    p = summary_plan(plan, None, s_layer)
    par = kernel_params(p)
    status, t, y, slide_x, n_rhs, n_steps = _paper_kernel(
        par,
        initial_state(p),
        np.ascontiguousarray(p.friction_x_edges_m, dtype=np.float64),
        np.ascontiguousarray(p.friction_y_edges_m, dtype=np.float64),
        np.ascontiguousarray(p.friction_mu, dtype=np.float64),
        float(p.lane_length_m),
        float(p.lane_width_m),
        float(dt),
        float(threshold),
        float(p.max_time_s),
        bool(needs_orientation(p)),
        snap == "impulse",
    )
    slide = None if math.isnan(slide_x) else float(slide_x)
    return result_dict(
        p, OUTCOMES.get(int(status), "error"), slide, t, y, n_rhs, n_steps=int(n_steps)
    )
