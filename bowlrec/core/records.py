"""The typed records the integrator's parts pass to each other (numba named tuples).

Each groups values that travel together, so a call names what it hands over (``law.mu``,
``run.rtol``) instead of a long row of positional floats that would still compile with two of them
swapped. Named tuples, not jitclasses: functions that take jitclass instances are not cached on
disk across processes (numba issues #6522 and #9659), so every process would compile the kernels
anew.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class RunSettings(NamedTuple):
    """What stays fixed for one run."""

    #: kernel parameters (see :func:`bowlrec.core.dynamics.pack_params`)
    par: np.ndarray
    #: relative tolerance of the error control (dimensionless)
    rtol: float
    #: where rolling starts: SLIDE_TO_ROLL_EXACT or SLIDE_TO_ROLL_THRESHOLD (codes)
    slide_mode: int
    #: the paper's slide -> roll threshold on |slip| (m/s), for SLIDE_TO_ROLL_THRESHOLD
    slip_threshold: float
    #: slip speed below which the slip direction is not integrated (m/s): a falling slip
    #: enters the slip layer at s_layer / 2
    s_layer: float
    #: slip speed at which a slip leaves the slip layer (m/s; ``arguments.restart_layer``)
    s_restart: float
    #: integrate the quaternion
    orient: bool
    #: how far the friction a rolling ball needs may exceed mu n before it slides (m/s^2)
    margin_tol: float
    #: the run ends at this time (s)
    max_time: float
    #: the run ends after this many accepted steps
    max_steps: int
    #: RECORD_SUMMARY, RECORD_STEPS or RECORD_RATE (codes)
    record_mode: int


class FrictionLaw(NamedTuple):
    """The friction law in force between two events."""

    #: PHASE_SLIDE, PHASE_ROLL or PHASE_LAYER (codes)
    phase: int
    #: friction coefficient under the ball
    mu: float
    #: unit reference direction: of the slip at the step's start (sliding), of the friction
    #: force (slip layer); unused while rolling
    ux: float
    uy: float


class Workspace(NamedTuple):
    """Arrays the integrator owns and overwrites; nothing in them outlives a call."""

    #: stage derivatives of the Dormand-Prince step (7, N_STATE); K[0] = f(y) at the step's start
    K: np.ndarray
    #: a stage's state, the 5th-order solution at the step's end, a dense-output state and a
    #: derivative nobody keeps (N_STATE each)
    ytmp: np.ndarray
    ynew: np.ndarray
    ybuf: np.ndarray
    dtmp: np.ndarray
    #: coefficients of the dense output of the last step (5, N_STATE)
    rc: np.ndarray
    #: event-function values (N_EVENT_FUNCTIONS each): scratch, at the previous and the current
    #: scan point
    gv: np.ndarray
    gprev: np.ndarray
    gcur: np.ndarray
    #: the current friction cell and the lane: x_lo, x_hi, y_lo, y_hi, length, width (m)
    bounds: np.ndarray


class Clock(NamedTuple):
    """Where the integration stands."""

    #: time (s) and the next step size (s)
    t: float
    h: float
    #: log of the last accepted error (at least log 1e-4), for the PI controller
    lfacold: float
    #: accepted steps and right-hand sides so far
    n_steps: int
    n_rhs: int


class Advanced(NamedTuple):
    """What :func:`bowlrec.core.integrator.advance` reports."""

    #: ADV_* (integrator)
    code: int
    clock: Clock
    #: the law with its reference direction as it was in the last step
    law: FrictionLaw
    #: event function found inside the last accepted step (-1: none) and where (s)
    event: int
    t_event: float
    #: start and size (s) of the last accepted step
    t0: float
    h0: float
    #: friction direction at its end
    ux_end: float
    uy_end: float
    #: the last step holds an observation (core.observe); its dense output is in ``ws.rc``
    observed: bool
