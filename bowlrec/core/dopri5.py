"""The Dormand-Prince 5(4) method: tableau, stages, embedded error and dense output.

One step from (t, y) with K[0] = f(y) computes stages 2..7 (FSAL: the 7th is f at the new point,
the next step's K[0]), the 5th-order solution, the embedded 5th - 4th order error estimate and
the 4th-order continuous extension (Hairer, Norsett and Wanner, "Solving Ordinary Differential
Equations I", Sec. II.5-II.6; the coefficients of their DOPRI5 code). The right-hand side is
:func:`bowlrec.core.dynamics.rhs` under a :class:`~bowlrec.core.records.FrictionLaw`.
"""

from __future__ import annotations

import math

from numba import njit

from .codes import N_STATE, S_QW, S_WX
from .dynamics import rhs
from .vec import NO_NRT

C2, C3, C4, C5 = 0.2, 0.3, 0.8, 8.0 / 9.0
A21 = 0.2
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0,
    -355.0 / 33.0,
    46732.0 / 5247.0,
    49.0 / 176.0,
    -5103.0 / 18656.0,
)
A71, A73, A74, A75, A76 = (
    35.0 / 384.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
)
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
)
D1, D3, D4, D5, D6, D7 = (
    -12715105075.0 / 11282082432.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
)
N_STAGES = 7
#: right-hand sides one step evaluates (stages 2..7; the first is the last step's 7th)
RHS_PER_STEP = 6


#: the slip's error scale is rtol * (SLIP_SCALE_MPS + |s|) (m/s): see :func:`error_norm`
SLIP_SCALE_MPS = 0.03


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def stages(y, h, ws, law, run):  # type: ignore[no-untyped-def]
    """Stages 2..7 of one step of size h (s) from y with ``ws.K[0]`` = f(y); the 5th-order
    solution goes to ``ws.ynew``. Returns the minimum normal force and friction margin (per unit
    mass, m/s^2) over stages 2..7 and the normal force, margin and friction direction (ux, uy)
    at the end of the step."""
    n = N_STATE
    K = ws.K
    ytmp = ws.ytmp
    ynew = ws.ynew
    par = run.par
    phase, mu, uxr, uyr = law.phase, law.mu, law.ux, law.uy
    orient = run.orient
    nmin = 1e300
    mmin = 1e300
    for i in range(n):
        ytmp[i] = y[i] + h * A21 * K[0, i]
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[1])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A31 * K[0, i] + A32 * K[1, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[2])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A41 * K[0, i] + A42 * K[1, i] + A43 * K[2, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[3])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A51 * K[0, i] + A52 * K[1, i] + A53 * K[2, i] + A54 * K[3, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[4])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (
            A61 * K[0, i] + A62 * K[1, i] + A63 * K[2, i] + A64 * K[3, i] + A65 * K[4, i]
        )
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[5])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ynew[i] = y[i] + h * (
            A71 * K[0, i] + A73 * K[2, i] + A74 * K[3, i] + A75 * K[4, i] + A76 * K[5, i]
        )
    r = rhs(ynew, par, phase, mu, uxr, uyr, orient, K[6])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    return nmin, mmin, r[0], r[1], r[2], r[3]


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _embedded_error(K, h, i):  # type: ignore[no-untyped-def]
    """Component i of the embedded (5th - 4th order) error estimate of a step of size h."""
    return h * (
        E1 * K[0, i] + E3 * K[2, i] + E4 * K[3, i] + E5 * K[4, i] + E6 * K[5, i] + E7 * K[6, i]
    )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def error_norm(y, ynew, K, h, rtol, q_weight, slip_r):  # type: ignore[no-untyped-def]
    """RMS of the embedded error estimate scaled by rtol * (1 + |y|) per component.

    The quaternion's error counts with the weight ``q_weight`` (0 drops it): see
    ``arguments.orientation_weight``. (Three loops in component order, so the sum is the same.)

    ``slip_r`` > 0 (the ball's radius, m, while the ball slides) adds the slip
    s = (R w_y - v_x, -R w_x - v_y) as two components of their own, scaled by
    rtol * (SLIP_SCALE_MPS + |s|). The slip is the small difference of v and R w (both several
    m/s): controlled only through them, its absolute error is ~10 rtol m/s, and where rolling is
    marginal (the slip lingers at a few mm/s before it vanishes) that error moves the slide ->
    roll point by decimetres. Over the work-precision benchmark's 218 deliveries the worst slide
    error at rtol 3e-5 goes from 561 mm to 1.4 mm with it (benchmarks/results/work_precision.md).
    ``slip_r`` = 0 (rolling: the slip is zero by construction) leaves the term out."""
    acc = 0.0
    for i in range(S_QW):
        sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
        acc += (_embedded_error(K, h, i) / sc) ** 2
    cnt = N_STATE - 4
    if q_weight != 0.0:
        cnt = N_STATE
        for i in range(S_QW, S_WX):
            sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
            acc += (q_weight * _embedded_error(K, h, i) / sc) ** 2
    for i in range(S_WX, N_STATE):
        sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
        acc += (_embedded_error(K, h, i) / sc) ** 2
    if slip_r > 0.0:
        ex = slip_r * _embedded_error(K, h, S_WX + 1) - _embedded_error(K, h, 2)
        ey = -slip_r * _embedded_error(K, h, S_WX) - _embedded_error(K, h, 3)
        s0x = slip_r * y[S_WX + 1] - y[2]
        s0y = -slip_r * y[S_WX] - y[3]
        s1x = slip_r * ynew[S_WX + 1] - ynew[2]
        s1y = -slip_r * ynew[S_WX] - ynew[3]
        s_big = max(math.sqrt(s0x * s0x + s0y * s0y), math.sqrt(s1x * s1x + s1y * s1y))
        sc = rtol * (SLIP_SCALE_MPS + s_big)
        acc += (ex / sc) ** 2 + (ey / sc) ** 2
        cnt += 2
    return math.sqrt(acc / cnt)


@njit(cache=True, error_model="numpy", **NO_NRT)
def dense_coeffs(y, ynew, K, h, rc):  # type: ignore[no-untyped-def]
    """Coefficients ``rc`` (5, N_STATE) of the continuous extension of the step y -> ynew."""
    for i in range(N_STATE):
        ydiff = ynew[i] - y[i]
        bspl = h * K[0, i] - ydiff
        rc[0, i] = y[i]
        rc[1, i] = ydiff
        rc[2, i] = bspl
        rc[3, i] = ydiff - h * K[6, i] - bspl
        rc[4, i] = h * (
            D1 * K[0, i] + D3 * K[2, i] + D4 * K[3, i] + D5 * K[4, i] + D6 * K[5, i] + D7 * K[6, i]
        )


@njit(cache=True, error_model="numpy", **NO_NRT)
def dense(rc, theta, out):  # type: ignore[no-untyped-def]
    """The state at the fraction ``theta`` of the step (0: its start, 1: its end) into ``out``."""
    th1 = 1.0 - theta
    for i in range(N_STATE):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + th1 * (rc[2, i] + theta * (rc[3, i] + th1 * rc[4, i]))
        )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def dense_planar(rc, theta, out):  # type: ignore[no-untyped-def]
    """Like :func:`dense` for the components the position, lane and slip events read (x, y, v,
    w_x, w_y)."""
    th1 = 1.0 - theta
    for i in (0, 1, 2, 3, 8, 9):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + th1 * (rc[2, i] + theta * (rc[3, i] + th1 * rc[4, i]))
        )
