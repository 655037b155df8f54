"""Step-size control: the starting step, the PI controller, rejections and the slip layer.

Hairer's DOPRI5 control (Hairer, Norsett and Wanner, Sec. II.4 and IV.2): a step is accepted when
the error norm is at most 1; the next step is h * 0.9 err^-0.2 errold^0.08 within [h / 5, 10 h],
with no growth right after a rejection. A rejected step shrinks by (0.9 / err)^(1/5), at most 10x;
after consecutive rejections whose error did not fall as h^5 (near the kink of a restarting slip
it falls ~ h^1) it is cut at the order they showed. While sliding, a step is aimed at the slip
layer instead of across it (see the integrator's module docstring).
"""

from __future__ import annotations

import math

from numba import njit

from .codes import N_STATE, PHASE_LAYER, PHASE_ROLL, PHASE_SLIDE, S_QW, S_WX
from .dynamics import P_QWEIGHT, rhs, slip
from .tsit5 import SLIP_SCALE_MPS
from .vec import NO_NRT

H_MAX = 0.1  #: largest step (s)
#: a sliding step is aimed to leave at least this fraction of the slip (or s_layer / 4): a step
#: that plans to take the slip most of the way to zero is mostly rejected, since the slip's
#: direction turns faster the smaller it gets. Over the 2,218 deliveries of
#: benchmarks/speed_limit.py at rtol 2e-4: 0.3 takes 6 % fewer right-hand sides than 0 (0.15:
#: 4 %, 0.5: 3 %), every worst error unchanged.
AIM_FRACTION = 0.3
LOG_1E_4 = math.log(1e-4)  #: the PI controller's floor of the previous error (log)


@njit(cache=True, error_model="numpy", **NO_NRT)
def initial_step(y, ws, law, run):  # type: ignore[no-untyped-def]
    """Starting step size (s) for y with ``ws.K[0]`` = f(y): Hairer's estimate (DOPRI5's
    ``hinit``), from |f| and a finite-difference second derivative (one extra right-hand side),
    in the same weighted norm as the error control (with the slip while sliding, as
    ``tsit5.error_norm`` counts it), so that the first step's error is ~ the tolerance."""
    K = ws.K
    ytmp = ws.ytmp
    dtmp = ws.dtmp
    par = run.par
    rtol = run.rtol
    qw = par[P_QWEIGHT]
    dny = 0.0
    dnf = 0.0
    for i in range(N_STATE):
        w = qw if S_QW <= i < S_WX else 1.0
        sc = rtol * (1.0 + abs(y[i]))
        dny += (w * y[i] / sc) ** 2
        dnf += (w * K[0, i] / sc) ** 2
    sliding = law.phase != PHASE_ROLL
    if sliding:
        # the slip as the error norm counts it (tsit5.error_norm)
        sx, sy = slip(y, par)
        sc_s = rtol * (SLIP_SCALE_MPS + math.sqrt(sx * sx + sy * sy))
        dsx, dsy = slip(K[0], par)
        dny += (sx * sx + sy * sy) / sc_s**2
        dnf += (dsx * dsx + dsy * dsy) / sc_s**2
    h = 0.01 * math.sqrt(dny / dnf) if dnf > 1e-10 and dny > 1e-10 else 1e-6
    h = min(h, H_MAX)
    for i in range(N_STATE):
        ytmp[i] = y[i] + h * K[0, i]
    rhs(ytmp, par, law.phase, law.mu, law.ux, law.uy, run.orient, dtmp)
    der2 = 0.0
    for i in range(N_STATE):
        w = qw if S_QW <= i < S_WX else 1.0
        sc = rtol * (1.0 + abs(y[i]))
        der2 += (w * (dtmp[i] - K[0, i]) / sc) ** 2
    if sliding:
        d1x, d1y = slip(dtmp, par)
        der2 += ((d1x - dsx) ** 2 + (d1y - dsy) ** 2) / sc_s**2
    der12 = max(math.sqrt(der2) / h, math.sqrt(dnf))
    h1 = (0.01 / der12) ** 0.2 if der12 > 1e-15 else max(1e-6, h * 1e-3)
    return max(1e-6, min(100.0 * h, h1, H_MAX))


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def after_accept(h, err, lfacold, rejected):  # type: ignore[no-untyped-def]
    """The next step (s) after an accepted step h with error norm ``err``, and the new
    ``lfacold``; ``rejected``: the step was accepted right after a rejection (no growth).

    PI control: h * 0.9 err^-0.2 errold^0.08 within [h / 5, 10 h] (Hairer's DOPRI5; one exp and
    one log instead of two powers)."""
    lerr = math.log(max(err, 1e-300))
    fac = max(0.1, min(5.0, math.exp(0.2 * lerr - 0.08 * lfacold) / 0.9))
    if rejected:
        h_next = min(h, h / fac, H_MAX)
    else:
        h_next = min(h / fac, H_MAX)
    return h_next, max(lerr, LOG_1E_4)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def after_reject(h, err, n_rejected, err_rej, h_rej):  # type: ignore[no-untyped-def]
    """The step (s) to retry after rejecting step h with error norm ``err`` (NaN: 10x smaller);
    ``n_rejected`` rejections came right before it, the last with error ``err_rej`` at step
    ``h_rej``."""
    if err != err:
        return 0.1 * h
    # h * (0.9 / err)^(1/5), at most 10x smaller ...
    hn = h / min(10.0, math.exp(0.2 * math.log(err)) / 0.9)
    if n_rejected > 0 and not (err < err_rej and h < h_rej):
        hn = min(hn, 0.2 * h)  # ... 5x at least if the error did not fall ...
    elif n_rejected > 0:
        # ... and if it fell slower than h^5 (near the kink of a restarting slip it falls
        # ~ h^1), cut at the order the last two rejections showed
        p_eff = math.log(err_rej / err) / math.log(h_rej / h)
        if p_eff < 4.0:
            p_eff = max(p_eff, 0.5)
            hn = min(hn, max(h * (0.8 / err) ** (1.0 / p_eff), 0.1 * h))
    return hn


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def aim_at_slip_layer(y, K, h, law, run):  # type: ignore[no-untyped-def]
    """The step (s) and reference direction (ux, uy) for the next try from y (``K[0]`` = f(y)).

    Sliding: the direction is that of the slip now, and the step ends about where the linearly
    extrapolated slip reaches s_layer / 4 (or AIM_FRACTION of the slip now): near |s| = 0 the
    Coulomb direction is singular, and a step whose stages land there can miss the root (a
    curved approach passes beside zero).
    Inside the layer the slip runs straight to zero (``radial_direction``) and the root is an
    ordinary sign change; the direction follows the slip while it is not tiny."""
    ux = law.ux
    uy = law.uy
    s_layer = run.s_layer
    if law.phase == PHASE_SLIDE:
        sx, sy = slip(y, run.par)
        s0 = math.sqrt(sx * sx + sy * sy)
        if s0 > 0.0:
            ux = sx / s0
            uy = sy / s0
            dsx, dsy = slip(K[0], run.par)  # ds/dt: slip() is linear in the state
            decay = -(ux * dsx + uy * dsy)
            if decay > 0.0 and s0 > 0.5 * s_layer:
                h_layer = (s0 - max(0.25 * s_layer, AIM_FRACTION * s0)) / decay
                if h > h_layer:
                    h = h_layer
    elif law.phase == PHASE_LAYER:
        sx, sy = slip(y, run.par)
        s0 = math.sqrt(sx * sx + sy * sy)
        if s0 > 1e-2 * s_layer:
            ux = sx / s0
            uy = sy / s0
    return h, ux, uy
