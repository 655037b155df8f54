"""Tsitouras' 5(4) Runge-Kutta pair: tableau, stages, embedded error and dense output.

One step from (t, y) with K[0] = f(y) computes stages 2..7 (FSAL: the 7th is f at the new point,
the next step's K[0]), the 5th-order solution, the embedded 5th - 4th order error estimate and
the 4th-order continuous extension: Ch. Tsitouras, "Runge-Kutta pairs of order 5(4) satisfying
only the first column simplifying assumption", Comput. Math. Appl. 62, 770 (2011), with the
double-precision coefficients as OrdinaryDiffEq.jl's ``Tsit5ConstantCache`` and ``Tsit5Interp``
give them (``tests/test_tsit5.py`` checks them against the order conditions). Like
Dormand-Prince 5(4) it has 7 stages, the last at the new point, so a step costs 6 right-hand
sides; its principal error coefficients are smaller, and on the work-precision benchmark's
deliveries it meets the same accuracy with fewer right-hand sides
(``benchmarks/results/rk_pair.md``). The right-hand side is :func:`bowlrec.core.dynamics.rhs`
under a :class:`~bowlrec.core.records.FrictionLaw`; the problem is autonomous, so the nodes
c_i enter only through the stage rows.
"""

from __future__ import annotations

import math

from numba import njit

from .codes import N_STATE, S_QW, S_WX
from .dynamics import rhs
from .vec import NO_NRT

# --- the pair (the method is these constants: benchmarks/rk_pair.py swaps this block) ---
#: stage rows a_ij (row i sums to c_i: 0.161, 0.327, 0.9, 0.98002554..., 1, 1)
A21 = 0.161
A31, A32 = -0.008480655492356989, 0.335480655492357
A41, A42, A43 = 2.8971530571054935, -6.359448489975075, 4.3622954328695815
A51, A52, A53, A54 = (
    5.325864828439257,
    -11.748883564062828,
    7.4955393428898365,
    -0.09249506636175525,
)
A61, A62, A63, A64, A65 = (
    5.86145544294642,
    -12.92096931784711,
    8.159367898576159,
    -0.071584973281401,
    -0.028269050394068383,
)
#: the 5th-order solution's weights b_i (stage 7 is evaluated at this point: FSAL)
A71, A72, A73, A74, A75, A76 = (
    0.09646076681806523,
    0.01,
    0.4798896504144996,
    1.379008574103742,
    -3.290069515436081,
    2.324710524099774,
)
#: error weights b_i - b_hat_i (b_hat: the embedded 4th-order solution)
E1, E2, E3, E4, E5, E6, E7 = (
    -0.00178001105222577714,
    -0.0008164344596567469,
    0.007880878010261995,
    -0.1447110071732629,
    0.5823571654525552,
    -0.45808210592918697,
    0.015151515151515152,
)
#: continuous extension b_i(theta) = theta + R_i2 theta^2 + R_i3 theta^3 + R_i4 theta^4 for
#: i = 1 and R_i2 theta^2 + R_i3 theta^3 + R_i4 theta^4 otherwise (b_i(1) = b_i)
R12, R13, R14 = -2.763706197274826, 2.9132554618219126, -1.0530884977290216
R22, R23, R24 = 0.13169999999999998, -0.2234, 0.1017
R32, R33, R34 = 3.9302962368947516, -5.941033872131505, 2.490627285651253
R42, R43, R44 = -12.411077166933676, 30.33818863028232, -16.548102889244902
R52, R53, R54 = 37.50931341651104, -88.1789048947664, 47.37952196281928
R62, R63, R64 = -27.896526289197286, 65.09189467479366, -34.87065786149661
R72, R73, R74 = 1.5, -4.0, 2.5
# --- end of the pair ---

#: the extension as the kernel evaluates it: y(theta) = y + theta D + theta (1 - theta)
#: (h f(y) - D + theta (U + theta V)) with D = ynew - y the step's increment,
#: U = h sum U_i K_i and V = h sum V_i K_i; it passes through both ends of the step exactly and
#: starts with slope f(y)
U1, U2, U3, U4, U5, U6, U7 = (
    -(R13 + R14),
    -(R23 + R24),
    -(R33 + R34),
    -(R43 + R44),
    -(R53 + R54),
    -(R63 + R64),
    -(R73 + R74),
)
V1, V2, V3, V4, V5, V6, V7 = -R14, -R24, -R34, -R44, -R54, -R64, -R74

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
            A71 * K[0, i]
            + A72 * K[1, i]
            + A73 * K[2, i]
            + A74 * K[3, i]
            + A75 * K[4, i]
            + A76 * K[5, i]
        )
    r = rhs(ynew, par, phase, mu, uxr, uyr, orient, K[6])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    return nmin, mmin, r[0], r[1], r[2], r[3]


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _over_stages(K, i, c1, c2, c3, c4, c5, c6, c7):  # type: ignore[no-untyped-def]
    """sum_j c_j K[j - 1, i] over the 7 stages, added in stage order."""
    return (
        c1 * K[0, i]
        + c2 * K[1, i]
        + c3 * K[2, i]
        + c4 * K[3, i]
        + c5 * K[4, i]
        + c6 * K[5, i]
        + c7 * K[6, i]
    )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _embedded_error(K, h, i):  # type: ignore[no-untyped-def]
    """Component i of the embedded (5th - 4th order) error estimate of a step of size h."""
    return h * _over_stages(K, i, E1, E2, E3, E4, E5, E6, E7)


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
    error at rtol 3e-5 is 0.66 mm with it (benchmarks/results/work_precision.md); without it,
    ~560 mm from rtol 2e-4 down to 3e-5 (measured with Dormand-Prince's pair).
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
        rc[0, i] = y[i]
        rc[1, i] = ydiff
        rc[2, i] = h * K[0, i] - ydiff
        rc[3, i] = h * _over_stages(K, i, U1, U2, U3, U4, U5, U6, U7)
        rc[4, i] = h * _over_stages(K, i, V1, V2, V3, V4, V5, V6, V7)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _dense_component(rc, theta, th1, i):  # type: ignore[no-untyped-def]
    """Component i of the continuous extension at ``theta`` (``th1`` = 1 - theta)."""
    return rc[0, i] + theta * (rc[1, i] + th1 * (rc[2, i] + theta * (rc[3, i] + theta * rc[4, i])))


@njit(cache=True, error_model="numpy", **NO_NRT)
def dense(rc, theta, out):  # type: ignore[no-untyped-def]
    """The state at the fraction ``theta`` of the step (0: its start, 1: its end) into ``out``."""
    th1 = 1.0 - theta
    for i in range(N_STATE):
        out[i] = _dense_component(rc, theta, th1, i)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def dense_planar(rc, theta, out):  # type: ignore[no-untyped-def]
    """Like :func:`dense` for the components the position, lane and slip events read (x, y, v,
    w_x, w_y)."""
    th1 = 1.0 - theta
    for i in (0, 1, 2, 3, 8, 9):
        out[i] = _dense_component(rc, theta, th1, i)
