"""Observation events: the state where the path crosses given stations x = X_k, and at its
turning points across the lane (v_y = 0), read off the dense output of accepted steps; with
them the release state and the run's last state (``OBS_RELEASE``, ``OBS_END``).

Unlike the events of :mod:`~bowlrec.core.events`, an observation changes nothing: the integrator
does not stop or restart there, so a run's steps, results and right-hand-side counts are the
same with or without them. Roots are found by bisection on the step's dense output (4th order,
the accuracy of the step itself) to ~1e-15 relative in time.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .codes import N_OBSCOL, N_STATE, OBS_STATE, OBS_T, OBS_TURN, OBS_WHAT, S_VY, S_X
from .tsit5 import dense, dense_planar
from .vec import NO_NRT

#: bisection steps on one step's dense output (2**-60 of the step: below rounding)
_BISECTIONS = 60


@njit(cache=True, error_model="numpy", **NO_NRT)
def _root(rc, component, target, theta_hi, ybuf):  # type: ignore[no-untyped-def]
    """theta in (0, theta_hi] where dense component ``component`` crosses ``target`` (the
    signs at 0 and at theta_hi differ)."""
    dense_planar(rc, 0.0, ybuf)
    below = ybuf[component] < target
    lo = 0.0
    hi = theta_hi
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        dense_planar(rc, mid, ybuf)
        if (ybuf[component] < target) == below:
            lo = mid
        else:
            hi = mid
    return hi


@njit(cache=True, error_model="numpy")
def push_observation(obs, nobs, t, what, y):  # type: ignore[no-untyped-def]
    """Append the state y at time t (s) as observation ``what`` (station index or OBS_*)."""
    if nobs >= obs.shape[0]:
        bigger = np.empty((2 * obs.shape[0], N_OBSCOL))
        bigger[: obs.shape[0]] = obs
        obs = bigger
    obs[nobs, OBS_T] = t
    obs[nobs, OBS_WHAT] = what
    for i in range(N_STATE):
        obs[nobs, OBS_STATE + i] = y[i]
    return obs, nobs + 1


#: the watch array: the next station's x (m; +inf: none left), 1.0 to observe turning points,
#: the index of the next station
W_NEXT_X, W_TURNS, W_INDEX = 0, 1, 2


@njit(cache=True, error_model="numpy")
def start_watch(stations, turns, x0):  # type: ignore[no-untyped-def]
    """The watch array for ``stations`` (ascending x, m; those at or behind the release point
    ``x0`` are not observed) and ``turns``; None (and no observing compiled in) when
    ``stations`` is None."""
    if stations is None:
        return None
    watch = np.empty(3)
    k = np.searchsorted(stations, x0, side="right")
    watch[W_NEXT_X] = stations[k] if k < stations.shape[0] else np.inf
    watch[W_TURNS] = 1.0 if turns else 0.0
    watch[W_INDEX] = k
    return watch


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def watching(watch):  # type: ignore[no-untyped-def]
    """Something is left to observe (False when not observing at all)."""
    if watch is None:
        return False
    return watch[W_TURNS] != 0.0 or watch[W_NEXT_X] < np.inf


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def step_observed(y, ynew, watch):  # type: ignore[no-untyped-def]
    """True when the step from state y to ynew reaches the next station or, when turning
    points are observed, changes the sign of v_y (False when not observing at all)."""
    if watch is None:
        return False
    if ynew[S_X] >= watch[W_NEXT_X]:
        return True
    return watch[W_TURNS] != 0.0 and ((y[S_VY] < 0.0) != (ynew[S_VY] < 0.0))


@njit(cache=True, error_model="numpy")
def observe_step(rc, t0, h0, t_end, stations, watch, obs, nobs, ybuf):  # type: ignore[no-untyped-def]
    """Record the observations inside the accepted step from t0 (size h0, dense output ``rc``)
    up to t_end <= t0 + h0: the stations from ``watch``'s next one on that the path reaches by
    t_end and, when turning points are observed, a sign change of v_y. Updates ``watch``;
    returns (obs, nobs)."""
    theta_end = (t_end - t0) / h0
    dense_planar(rc, theta_end, ybuf)
    x_end = ybuf[S_X]
    vy_end = ybuf[S_VY]
    k = int(watch[W_INDEX])
    while k < stations.shape[0] and x_end >= stations[k]:
        theta = _root(rc, S_X, stations[k], theta_end, ybuf)
        dense(rc, theta, ybuf)
        ybuf[S_X] = stations[k]  # exactly on the station
        obs, nobs = push_observation(obs, nobs, t0 + theta * h0, float(k), ybuf)
        k += 1
        dense_planar(rc, theta_end, ybuf)
    watch[W_INDEX] = k
    watch[W_NEXT_X] = stations[k] if k < stations.shape[0] else np.inf
    if watch[W_TURNS] != 0.0:
        dense_planar(rc, 0.0, ybuf)
        if (ybuf[S_VY] < 0.0) != (vy_end < 0.0):
            theta = _root(rc, S_VY, 0.0, theta_end, ybuf)
            dense(rc, theta, ybuf)
            obs, nobs = push_observation(obs, nobs, t0 + theta * h0, float(OBS_TURN), ybuf)
    return obs, nobs
