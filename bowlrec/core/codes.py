"""The integer codes and array layouts that the kernels and their readers share, with their names.

Every number that crosses the boundary of a compiled kernel is defined here once: the layout of
the state vector, the friction phases, how a run ended (status), what happened at an event, the
columns of the sample and event tables the kernels fill, and the recording and slide -> roll
modes of a :class:`~bowlrec.core.plan.Plan`. Plain integers (numba folds module-level integers
into the kernels as constants) and plain dictionaries for their names; no imports, so every layer
may use it.
"""

from __future__ import annotations

# ---- the state vector (SI units, lane frame; see bowlrec.core.dynamics) ----
S_X, S_Y = 0, 1  #: position of the geometric center (m); it stays at z = 0
S_VX, S_VY = 2, 3  #: velocity of the geometric center (m/s)
S_QW, S_QX, S_QY, S_QZ = 4, 5, 6, 7  #: unit quaternion (w, x, y, z), body -> lane frame
S_WX, S_WY, S_WZ = 8, 9, 10  #: angular velocity in the lane frame (rad/s)
N_STATE = 11

# ---- friction phases of the kernels ----
PHASE_SLIDE = 0  #: sliding: Coulomb friction along the slip
PHASE_ROLL = 1  #: rolling without slip: the friction the rolling ball needs
#: sliding right after the slip restarted from zero: the friction acts along the slaved direction
#: (the direction along which the slip grows along itself) until the slip is established
PHASE_LAYER = 2

#: the phase as a trajectory and an event report it (the slip layer is sliding)
SLIDING = 0
ROLLING = 1
PHASE_NAMES = {SLIDING: "sliding", ROLLING: "rolling"}

# ---- how a run ended ----
STATUS_RUNNING = 0
STATUS_PINS = 1
STATUS_GUTTER = 2
STATUS_STOPPED = 3
STATUS_AIRBORNE = 4
STATUS_MAX_TIME = 5
STATUS_MAX_STEPS = 6
STATUS_STALLED = 7
#: the outcome names of the end statuses (what summaries, tables and archives store)
OUTCOMES = {
    STATUS_PINS: "pins",
    STATUS_GUTTER: "gutter",
    STATUS_STOPPED: "stopped",
    STATUS_AIRBORNE: "airborne",
    STATUS_MAX_TIME: "max_time",
    STATUS_MAX_STEPS: "max_steps",
    STATUS_STALLED: "stalled",
}

# ---- what happened at an event ----
EVENT_SLIDE_TO_ROLL = 1
EVENT_ROLL_TO_SLIDE = 2
EVENT_ZONE = 3
EVENT_PINS = 4
EVENT_GUTTER = 5
EVENT_STOPPED = 6
EVENT_AIRBORNE = 7
EVENT_MAX_TIME = 8
EVENT_SLIP_REVERSAL = 9
EVENT_KINDS = {
    EVENT_SLIDE_TO_ROLL: "slide_to_roll",
    EVENT_ROLL_TO_SLIDE: "roll_to_slide",
    EVENT_ZONE: "zone",
    EVENT_PINS: "pins",
    EVENT_GUTTER: "gutter",
    EVENT_STOPPED: "stopped",
    EVENT_AIRBORNE: "airborne",
    EVENT_MAX_TIME: "max_time",
    EVENT_SLIP_REVERSAL: "slip_reversal",
}

# ---- columns of the sample table a kernel fills (one row per sample) ----
COL_T = 0  #: time (s)
COL_STATE = 1  #: the N_STATE state components follow (see S_*)
COL_PHASE = COL_STATE + N_STATE  #: kernel phase (PHASE_*)
COL_MU = COL_PHASE + 1  #: friction coefficient under the ball
COL_UX = COL_MU + 1  #: unit direction of the friction force, x
COL_UY = COL_UX + 1  #: and y
N_COL = COL_UY + 1

# ---- columns of the event table a kernel fills (one row per event) ----
EV_T = 0  #: time (s)
EV_KIND = 1  #: EVENT_*
EV_X, EV_Y = 2, 3  #: position of the center (m)
EV_MU = 4  #: friction coefficient under the ball after the event
EV_PHASE = 5  #: ROLLING or SLIDING after the event
N_EVCOL = 6

# ---- columns of the observation table a kernel fills (one row per observation) ----
OBS_T = 0  #: time (s)
OBS_WHAT = 1  #: index of the observed station x (0, 1, ...) or OBS_TURN
OBS_STATE = 2  #: the N_STATE state components follow (see S_*)
N_OBSCOL = OBS_STATE + N_STATE
#: OBS_WHAT of a turning point of the path across the lane (v_y = 0)
OBS_TURN = -1
#: OBS_WHAT of the release state and of the run's last state (recorded whenever observing)
OBS_RELEASE = -2
OBS_END = -3

# ---- what a run records (Plan.record_mode) ----
RECORD_SUMMARY = 0  #: keep no samples, only events and the summary
RECORD_STEPS = 1  #: one sample at every accepted integrator step (and every event)
RECORD_RATE = 2  #: samples at a fixed rate from the dense output (and every event)

# ---- where rolling starts (Plan.slide_to_roll) ----
SLIDE_TO_ROLL_EXACT = 0  #: rolling starts where the slip is exactly zero (root of the slip)
SLIDE_TO_ROLL_THRESHOLD = 1  #: the paper's rule: rolling starts once |slip| < slip_threshold

# ---- the Magnus lift coefficient's model (Plan.lift_model) ----
LIFT_NONE = 0  #: no Magnus lift
#: C_L(S) of Sawicki, Hubbard & Stronge (2003): 1.5 S for S <= 0.1, 0.09 + 0.6 S above
LIFT_SAWICKI = 1
LIFT_MODELS = ("none", "sawicki2003")  #: names by code
