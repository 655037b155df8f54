"""Compiled adaptive integrator with event location: one delivery from release to an outcome.

Method: Tsitouras' 5(4) pair (FSAL; Hairer's step-size control with a PI factor, no growth right
after a rejected step, and a steeper cut when consecutive rejections show the error falling
slower than h^5) and its 4th-order continuous extension for dense output. While the ball slides,
the error norm counts the slip too, scaled by rtol * (0.03 m/s + |s|) (``tsit5.error_norm``):
where the slip decides the slide -> roll point its absolute error is held near the tolerance
instead of ~10 rtol m/s. Events are located on
the dense output by safeguarded regula falsi (Illinois) to ~1e-15 relative in time; the state at
the event is the dense output there (its error is of the order of the step's own, as in the
root finding of SUNDIALS or DifferentialEquations.jl), and the integration restarts at every
event (the right-hand side is discontinuous there). The event functions are scanned at
4 points of the dense output only when one of them could change sign inside the step
(``events.may_cross``: bounds from the stage derivatives); most steps need just the two end values.

Events (a function g fires where it goes from >= 0 to < 0 between two dense samples):

* zone boundaries of the friction grid (restart with the new mu),
* the pins x = L (the summary is taken exactly there), the gutters y = 0 and y = W,
* vx = 0 (the ball stops or comes back: it cannot reach the pins),
* slide -> roll: g = s . u_ref with u_ref the slip direction at the start of the step. The friction
  direction is continued smoothly through s = 0 (see ``friction_direction``), so a step cannot
  jump over the kink of |s| and the root is an ordinary sign change. A root where |s| is not
  small (the slip turned by 90 degrees within a step) just refreshes u_ref. At a real root the
  residual slip (~ the tolerance) is removed by a tiny impulse at the contact point (physically
  consistent: it changes v and w as a friction impulse does);
* with the paper's rule (``slide_mode`` 1) slide -> roll fires where s . u_ref falls through the
  threshold, or at release when the slip starts under it; a slip that restarted from zero and
  never exceeded it rolls again at zero;
* roll -> slide: the friction reserve mu n - |f| of the rolling ball turns negative (checked at
  every stage and step end, then located on the dense output);
* loss of contact: the normal force turns negative (outcome "airborne").

Stiff restart of sliding. When a rolling ball starts to slip again, |s| grows from zero and the
slip direction relaxes at a rate ~ mu g (1 + R^2/k^2) / |s|; an explicit method would crawl with
~1e-9 s steps. The same stiffness appears whenever the slip lingers near zero (a ball at the edge
of the friction cone, the stick-slip of Table III cases 5 and 18). Below a slip speed ``s_layer``
(entered at s_layer / 2 by a falling slip, left at s_restart >= s_layer: hysteresis;
``arguments.restart_layer`` widens the exit at loose tolerances) bowlrec does not integrate the
stiff relaxation of the slip direction. Where rolling is possible (the rolling ball needs at most
mu n) every small slip reaches zero in finite time, and friction acts along the direction that
makes it shrink straight to zero (``dynamics.radial_direction``); otherwise (the slip restarts
from rolling) along the slaved direction (the unit u with ds/dt(u) parallel to +u, the |s| -> 0
limit of the exact dynamics). While sliding, a step is cut to end about where the linearly
extrapolated slip reaches the larger of s_layer / 4 and 0.3 of the slip at its start
(``step_control.AIM_FRACTION``), so steps do not jump across |s| = 0, where the Coulomb
direction is singular (a curved approach could pass beside the root unseen). The error this
introduces vanishes with s_layer; ``arguments.slip_layer`` ties it to the tolerance (1e-5 m/s at
rtol 1e-9, where against s_layer = 1e-8 m/s it moves hook, pocket and slide of cases 5 and 18 by
<= 4.6e-7 m, 3.2e-5 deg and 3.2e-8 m while taking 11-37x fewer right-hand sides).

The parts live in their own modules: the method's tableau, stages, error and dense output in
:mod:`~bowlrec.core.tsit5`, step-size control in :mod:`~bowlrec.core.step_control`, the event
functions and root finding in :mod:`~bowlrec.core.events`, the sample and event tables in
:mod:`~bowlrec.core.recording`, whether friction holds a rolling ball, the law at release and the
slide -> roll impulse in :mod:`~bowlrec.core.contact`, and the records they pass in
:mod:`~bowlrec.core.records`. This module drives them: :func:`advance` takes steps under one
friction law until something happens, :func:`simulate_kernel` handles what happened.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .codes import (
    COL_T,
    EVENT_AIRBORNE,
    EVENT_GUTTER,
    EVENT_MAX_TIME,
    EVENT_PINS,
    EVENT_ROLL_TO_SLIDE,
    EVENT_SLIDE_TO_ROLL,
    EVENT_SLIP_REVERSAL,
    EVENT_STOPPED,
    EVENT_ZONE,
    N_COL,
    N_EVCOL,
    N_OBSCOL,
    N_STATE,
    OBS_END,
    OBS_RELEASE,
    PHASE_LAYER,
    PHASE_ROLL,
    PHASE_SLIDE,
    RECORD_RATE,
    RECORD_STEPS,
    RECORD_SUMMARY,
    S_QW,
    S_X,
    S_Y,
    SLIDE_TO_ROLL_THRESHOLD,
    STATUS_AIRBORNE,
    STATUS_GUTTER,
    STATUS_MAX_STEPS,
    STATUS_MAX_TIME,
    STATUS_PINS,
    STATUS_RUNNING,
    STATUS_STALLED,
    STATUS_STOPPED,
)
from .contact import release_law, remove_slip, rolling_grip
from .dynamics import P_G, P_QWEIGHT, P_R, P_SLAYER, P_SRESTART, rhs, slaved_direction, slip
from .events import (
    G_CONTACT,
    G_GUTTER_LEFT,
    G_GUTTER_RIGHT,
    G_LAYER,
    G_PINS,
    G_RESERVE,
    G_SLIP_ZERO,
    G_STOP,
    G_X_HI,
    G_X_LO,
    G_Y_HI,
    G_Y_LO,
    N_BOUNDS,
    N_EVENT_FUNCTIONS,
    N_KINEMATIC,
    cell_bounds,
    dynamic_values,
    kinematic_values,
    locate,
    may_cross,
)
from .observe import observe_step, push_observation, start_watch, step_observed, watching
from .recording import push_event, push_sample
from .records import Advanced, Clock, FrictionLaw, RunSettings, Workspace
from .step_control import LOG_1E_4, after_accept, after_reject, aim_at_slip_layer, initial_step
from .tsit5 import (
    N_STAGES,
    RHS_PER_STEP,
    dense,
    dense_coeffs,
    dense_planar,
    error_norm,
    stages,
)
from .vec import NO_NRT

N_SCAN = 4  #: dense samples per step on which the event functions are scanned
MAX_EVENTS = 100_000  #: a run with more events than this stalled (endless phase switching)

# what advance() stopped for
ADV_EVENT = 0  #: an accepted step with an event inside it (or, when recording, any accepted step)
ADV_MAX_STEPS = 1
ADV_MAX_TIME = 2
ADV_STALLED = 3


@njit(cache=True)
def new_workspace():  # type: ignore[no-untyped-def]
    """A :class:`~bowlrec.core.records.Workspace` for one run (contents undefined)."""
    return Workspace(
        np.empty((N_STAGES, N_STATE)),
        np.empty(N_STATE),
        np.empty(N_STATE),
        np.empty(N_STATE),
        np.empty(N_STATE),
        np.empty((5, N_STATE)),
        np.empty(N_EVENT_FUNCTIONS),
        np.empty(N_EVENT_FUNCTIONS),
        np.empty(N_EVENT_FUNCTIONS),
        np.empty(N_BOUNDS),
    )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _normalize_quaternion(y):  # type: ignore[no-untyped-def]
    """Scale the quaternion of state y to unit length (in place)."""
    qn = math.sqrt(y[S_QW] ** 2 + y[S_QW + 1] ** 2 + y[S_QW + 2] ** 2 + y[S_QW + 3] ** 2)
    for i in range(S_QW, S_QW + 4):
        y[i] /= qn


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _stopped(code, clock, law):  # type: ignore[no-untyped-def]
    """advance()'s report when it stops at a limit before taking a step."""
    return Advanced(
        code=code,
        clock=clock,
        law=law,
        event=-1,
        t_event=1e300,
        t0=clock.t,
        h0=clock.h,
        ux_end=law.ux,
        uy_end=law.uy,
        observed=False,
    )


@njit(cache=True, error_model="numpy", **NO_NRT)
def advance(y, clock, law, run, ws, watch):  # type: ignore[no-untyped-def]
    """Take steps (same phase, zone and friction law) until one contains an event or a limit
    is hit; while recording, return after every accepted step, and after a step that holds an
    observation (``watch``: :func:`bowlrec.core.observe.start_watch`; None compiles a version
    that observes nothing).

    A step without an event is taken (y and ``ws.K[0]`` updated, the clock moved on) before
    returning; a step with an event is not (the clock's t and h are its start and size,
    ``ws.rc`` its dense output). Returns an :class:`~bowlrec.core.records.Advanced`."""
    t, h, lfacold, nsteps, nfev = clock
    K = ws.K
    ynew = ws.ynew
    ybuf = ws.ybuf
    rc = ws.rc
    gprev = ws.gprev
    gcur = ws.gcur
    par = run.par
    phase = law.phase
    nrej = 0  # consecutive rejections, the last one's error and step
    err_rej = 1.0
    h_rej = h
    while True:
        if nsteps >= run.max_steps:
            return _stopped(ADV_MAX_STEPS, Clock(t, h, lfacold, nsteps, nfev), law)
        if t >= run.max_time:
            return _stopped(ADV_MAX_TIME, Clock(t, h, lfacold, nsteps, nfev), law)
        if h < 1e-13 * max(1.0, t):
            return _stopped(ADV_STALLED, Clock(t, h, lfacold, nsteps, nfev), law)
        if t + h > run.max_time:
            h = run.max_time - t
        h, ux, uy = aim_at_slip_layer(y, K, h, law, run)
        law = FrictionLaw(phase, law.mu, ux, uy)
        st = stages(y, h, ws, law, run)
        nfev += RHS_PER_STEP
        slip_r = par[P_R] if phase != PHASE_ROLL else 0.0
        err = error_norm(y, ynew, K, h, run.rtol, par[P_QWEIGHT], slip_r)
        if not (err <= 1.0):
            hn = after_reject(h, err, nrej, err_rej, h_rej)
            err_rej = err
            h_rej = h
            nrej += 1
            h = hn
            continue
        nsteps += 1
        # ---- event scan on the dense output ----
        best_t = 1e300
        best_idx = -1
        kinematic_values(y, law, run, ws.bounds, gprev)
        kinematic_values(ynew, law, run, ws.bounds, gcur)
        scan = phase == PHASE_LAYER or may_cross(gprev, gcur, K, h, par, phase)
        # the normal force or (rolling) the friction reserve fell below zero at some stage
        dynamic = st[0] <= 0.0 or (phase == PHASE_ROLL and st[1] < -run.margin_tol)
        if scan or dynamic or run.record_mode == RECORD_RATE:
            dense_coeffs(y, ynew, K, h, rc)
        ta = t
        for j in range(1, N_SCAN + 1 if scan else 1):
            tj = t + h * j / N_SCAN
            if j == N_SCAN:
                for i in range(N_STATE):
                    ybuf[i] = ynew[i]
            else:
                dense_planar(rc, j / N_SCAN, ybuf)
            kinematic_values(ybuf, law, run, ws.bounds, gcur)
            for idx in range(N_KINEMATIC):
                if gprev[idx] >= 0.0 and gcur[idx] < 0.0:
                    te = locate(idx, ta, tj, t, h, law, run, ws)
                    if te < best_t:
                        best_t = te
                        best_idx = idx
            if best_idx >= 0:
                break
            for idx in range(N_KINEMATIC):
                gprev[idx] = gcur[idx]
            ta = tj
        # dynamic events: friction reserve (rolling) and contact
        if dynamic:
            m_prev, n_prev = dynamic_values(y, law, run, ws.dtmp)
            ta = t
            t_hi = best_t if best_idx >= 0 else t + h
            for j in range(1, N_SCAN + 1):
                tj = t + h * j / N_SCAN
                if tj > t_hi:
                    tj = t_hi
                dense(rc, (tj - t) / h, ybuf)
                m_cur, n_cur = dynamic_values(ybuf, law, run, ws.dtmp)
                nfev += 1
                found = -1
                if n_prev >= 0.0 and n_cur < 0.0:
                    found = G_CONTACT
                elif phase == PHASE_ROLL and m_prev >= -run.margin_tol and m_cur < -run.margin_tol:
                    found = G_RESERVE
                if found >= 0:
                    te = locate(found, ta, tj, t, h, law, run, ws)
                    if te <= best_t:
                        best_t = te
                        best_idx = found
                    break
                m_prev = m_cur
                n_prev = n_cur
                ta = tj
                if tj >= t_hi:
                    break

        if best_idx >= 0:
            return Advanced(
                code=ADV_EVENT,
                clock=Clock(t, h, lfacold, nsteps, nfev),
                law=law,
                event=best_idx,
                t_event=best_t,
                t0=t,
                h0=h,
                ux_end=st[4],
                uy_end=st[5],
                observed=watching(watch),
            )
        # plain accepted step
        observed = step_observed(y, ynew, watch)
        if observed and not (scan or dynamic or run.record_mode == RECORD_RATE):
            dense_coeffs(y, ynew, K, h, rc)
        t_start = t
        h_acc = h
        for i in range(N_STATE):
            y[i] = ynew[i]
            K[0, i] = K[N_STAGES - 1, i]
        t = t + h
        if run.orient:
            _normalize_quaternion(y)
        h, lfacold = after_accept(h, err, lfacold, nrej > 0)
        nrej = 0
        if run.record_mode != RECORD_SUMMARY or observed:
            return Advanced(
                code=ADV_EVENT,
                clock=Clock(t, h, lfacold, nsteps, nfev),
                law=law,
                event=-1,
                t_event=1e300,
                t0=t_start,
                h0=h_acc,
                ux_end=st[4],
                uy_end=st[5],
                observed=observed,
            )


@njit(cache=True, error_model="numpy")
def simulate_kernel(  # type: ignore[no-untyped-def]
    par,
    y_init,
    x_edges,
    y_edges,
    mu_grid,
    lane_length,
    lane_width,
    rtol,
    record_mode,
    record_dt,
    slide_mode,
    slip_threshold,
    max_time,
    max_steps,
    orient,
    stations,
    turns,
):
    """Integrate one delivery. See the module docstring.

    Returns (samples, n_samples, events, n_events, status, t_end, y_end, n_steps, n_rhs,
    observations, n_observations): the sample, event and observation tables (columns in
    :mod:`bowlrec.core.codes`) and their row counts, the STATUS_* code, the end time (s) and
    state, accepted steps and right-hand sides. ``stations``: ascending x (m) at which the state
    is observed, ``turns``: also at v_y = 0, with the release and the last state
    (:mod:`bowlrec.core.observe`; observing changes no result); None: nothing is observed and
    no observing is compiled in.
    ``record_mode``: RECORD_SUMMARY, RECORD_STEPS or RECORD_RATE (every ``record_dt`` s).
    ``slide_mode``: SLIDE_TO_ROLL_EXACT or SLIDE_TO_ROLL_THRESHOLD (|s| < slip_threshold).
    """
    g = par[P_G]
    s_layer = par[P_SLAYER]
    run = RunSettings(
        par=par,
        rtol=rtol,
        slide_mode=slide_mode,
        slip_threshold=slip_threshold,
        s_layer=s_layer,
        s_restart=par[P_SRESTART],
        orient=orient,
        margin_tol=rtol * g,
        max_time=max_time,
        max_steps=max_steps,
        record_mode=record_mode,
    )
    ws = new_workspace()
    K = ws.K
    dtmp = ws.dtmp
    y = y_init.copy()
    t = 0.0
    rec = np.empty((1024 if record_mode != RECORD_SUMMARY else 1, N_COL))
    nrec = 0
    ev = np.empty((16, N_EVCOL))
    nev = 0
    obs = np.empty((1, N_OBSCOL))
    nobs = 0
    watch = start_watch(stations, turns, y_init[S_X])
    if stations is not None:
        obs, nobs = push_observation(obs, nobs, 0.0, float(OBS_RELEASE), y)
    s_accept = s_layer  # a slip-direction root above the layer is a turn, not a zero
    margin_tol = run.margin_tol

    ix = np.searchsorted(x_edges, y[S_X], side="right")
    iy = np.searchsorted(y_edges, y[S_Y], side="right")
    mu = mu_grid[ix, iy]
    cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, ws.bounds)

    law = release_law(y, par, mu, margin_tol)
    phase, _, uxr, uyr = law
    if slide_mode == SLIDE_TO_ROLL_THRESHOLD and phase == PHASE_SLIDE:
        sx, sy = slip(y, par)
        if sx * sx + sy * sy < slip_threshold * slip_threshold:
            # the paper's rule at release: a slip already under the threshold rolls at once
            # (the slide -> roll event fires only where the slip falls through it)
            remove_slip(y, par)
            law = release_law(y, par, mu, margin_tol)
            phase, _, uxr, uyr = law
            if phase == PHASE_ROLL:
                ev, nev = push_event(ev, nev, t, EVENT_SLIDE_TO_ROLL, y, mu, phase)

    r0 = rhs(y, par, phase, mu, uxr, uyr, orient, K[0])
    nfev = 1
    if record_mode != RECORD_SUMMARY:
        rec, nrec = push_sample(rec, nrec, t, y, phase, mu, r0[2], r0[3])
    status = STATUS_RUNNING
    if r0[0] <= 0.0:
        status = STATUS_AIRBORNE
        ev, nev = push_event(ev, nev, t, EVENT_AIRBORNE, y, mu, phase)

    h = initial_step(y, ws, law, run)
    nfev += 1
    lfacold = LOG_1E_4
    t_next_sample = record_dt
    nsteps = 0
    n_transitions = 0

    while status == STATUS_RUNNING:
        adv = advance(y, Clock(t, h, lfacold, nsteps, nfev), law, run, ws, watch)
        t, h, lfacold, nsteps, nfev = adv.clock
        law = adv.law
        uxr = law.ux
        uyr = law.uy
        best_idx = adv.event
        best_t = adv.t_event
        t0 = adv.t0
        h0 = adv.h0
        if adv.code == ADV_MAX_STEPS:
            status = STATUS_MAX_STEPS
            break
        if adv.code == ADV_MAX_TIME:
            status = STATUS_MAX_TIME
            ev, nev = push_event(ev, nev, t, EVENT_MAX_TIME, y, mu, phase)
            break
        if adv.code == ADV_STALLED:
            status = STATUS_STALLED
            break
        # an accepted step from t0 to t0 + h0 (already taken unless an event lies inside it)
        t_step_end = t0 + h0 if best_idx < 0 else best_t
        # ---- samples at a fixed rate from the dense output ----
        if record_mode == RECORD_RATE:
            while t_next_sample <= t_step_end:
                dense(ws.rc, (t_next_sample - t0) / h0, ws.ybuf)
                rr = rhs(ws.ybuf, par, phase, mu, uxr, uyr, orient, dtmp)
                rec, nrec = push_sample(rec, nrec, t_next_sample, ws.ybuf, phase, mu, rr[2], rr[3])
                t_next_sample += record_dt
        # a condition on the argument alone: numba drops the branch when stations is None
        if stations is not None:  # noqa: SIM102
            if adv.observed:
                obs, nobs = observe_step(
                    ws.rc, t0, h0, t_step_end, stations, watch, obs, nobs, ws.ybuf
                )

        if best_idx < 0:
            if record_mode == RECORD_STEPS:
                rec, nrec = push_sample(rec, nrec, t, y, phase, mu, adv.ux_end, adv.uy_end)
            continue

        # ---- an event inside this step: the state there from the dense output ----
        if best_t > t:
            dense(ws.rc, (best_t - t) / h, y)
        t = best_t
        if orient:
            _normalize_quaternion(y)
        phase_before = phase
        lfacold = LOG_1E_4
        n_transitions += 1
        if n_transitions > MAX_EVENTS:
            status = STATUS_STALLED
            break
        if record_mode != RECORD_SUMMARY:
            rr = rhs(y, par, phase, mu, uxr, uyr, orient, dtmp)
            rec, nrec = push_sample(rec, nrec, t, y, phase, mu, rr[2], rr[3])

        if best_idx == G_PINS:
            status = STATUS_PINS
            ev, nev = push_event(ev, nev, t, EVENT_PINS, y, mu, phase)
        elif best_idx in (G_GUTTER_RIGHT, G_GUTTER_LEFT):
            status = STATUS_GUTTER
            ev, nev = push_event(ev, nev, t, EVENT_GUTTER, y, mu, phase)
        elif best_idx == G_STOP:
            status = STATUS_STOPPED
            ev, nev = push_event(ev, nev, t, EVENT_STOPPED, y, mu, phase)
        elif best_idx == G_CONTACT:
            status = STATUS_AIRBORNE
            ev, nev = push_event(ev, nev, t, EVENT_AIRBORNE, y, mu, phase)
        elif best_idx <= G_Y_LO:
            # friction zone crossing: step into the neighbouring cell
            if best_idx == G_X_HI:
                ix += 1
            elif best_idx == G_X_LO:
                ix -= 1
            elif best_idx == G_Y_HI:
                iy += 1
            else:
                iy -= 1
            mu = mu_grid[ix, iy]
            cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, ws.bounds)
            ev, nev = push_event(ev, nev, t, EVENT_ZONE, y, mu, phase)
        elif best_idx == G_SLIP_ZERO:
            sx, sy = slip(y, par)
            s_e = math.sqrt(sx * sx + sy * sy)
            turned = s_e > (
                1.5 * slip_threshold if slide_mode == SLIDE_TO_ROLL_THRESHOLD else s_accept
            )
            if phase == PHASE_SLIDE and turned:
                # not a zero of the slip: its direction turned within the step
                uxr = sx / s_e
                uyr = sy / s_e
            else:
                remove_slip(y, par)
                phase = PHASE_ROLL
                ev, nev = push_event(ev, nev, t, EVENT_SLIDE_TO_ROLL, y, mu, phase)
        elif best_idx == G_LAYER:
            sx, sy = slip(y, par)
            s_e = math.sqrt(sx * sx + sy * sy)
            if phase == PHASE_LAYER:
                # the slip is established: back to the plain Coulomb law along s
                uxr = sx / s_e
                uyr = sy / s_e
                phase = PHASE_SLIDE
            else:
                # the slip became tiny: friction along the slaved direction (not stiff)
                phase = PHASE_LAYER
                uxr, uyr = slaved_direction(y, par, mu, sx / s_e, sy / s_e)
        # G_RESERVE: handled by the friction-reserve check below

        if status != STATUS_RUNNING:
            break
        # a rolling ball that needs more friction than mu n starts to slide
        if phase == PHASE_ROLL:
            holds, fx, fy = rolling_grip(y, par, mu, margin_tol)
            if not holds or best_idx == G_RESERVE:
                # the slip restarts from zero along the friction the rolling ball needed
                phase = PHASE_LAYER
                uxr = fx
                uyr = fy
                kind = EVENT_SLIP_REVERSAL if best_idx == G_SLIP_ZERO else EVENT_ROLL_TO_SLIDE
                if best_idx == G_SLIP_ZERO:
                    # drop the slide->roll event we just recorded: the ball never rolled
                    nev -= 1
                ev, nev = push_event(ev, nev, t, kind, y, mu, phase)
        law = FrictionLaw(phase, mu, uxr, uyr)
        r0 = rhs(y, par, phase, mu, uxr, uyr, orient, K[0])
        nfev += 1
        if phase != phase_before:
            # the step size of the old phase says nothing about the new one (after a roll ->
            # slide -> roll cycle it was the slip layer's ~1e-5 s): start afresh
            h = initial_step(y, ws, law, run)
            nfev += 1
        else:
            h = max(h, 1e-6)
        if record_mode != RECORD_SUMMARY:
            rec, nrec = push_sample(rec, nrec, t, y, phase, mu, r0[2], r0[3])

    if record_mode != RECORD_SUMMARY and (nrec == 0 or rec[nrec - 1, COL_T] != t):
        r0 = rhs(y, par, phase, mu, uxr, uyr, orient, dtmp)
        rec, nrec = push_sample(rec, nrec, t, y, phase, mu, r0[2], r0[3])
    if stations is not None:
        obs, nobs = push_observation(obs, nobs, t, float(OBS_END), y)
    return rec, nrec, ev, nev, status, t, y, nsteps, nfev, obs, nobs
