"""The lane's height across it (small-slope topography): the natural cubic spline through a
height profile, and the largest slope of the profile plus a cross tilt.

The kernels add gravity's lateral component -g dz/dy at the center of mass
(``dynamics.external_accel``) and keep the contact geometry flat (normal along z): a
small-slope approximation, good to O(slope^2) ~ 1e-6 for the slopes allowed (|dz/dy| <= 1e-3).

The heights z_i at the knots y_i are joined by the natural cubic spline (z'' = 0 at both ends,
continued linearly beyond them): its slope is continuous and has a continuous derivative, so the
right-hand side of the equations of motion stays smooth across the knots and the integrator
needs no events there (piecewise-linear heights would make the slope jump at every knot).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["max_abs_slope", "natural_spline", "spline_slope"]


def natural_spline(y_m: NDArray[np.float64], z_m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Second derivatives z''_i (1/m) of the natural cubic spline through (y_i, z_i); y strictly
    ascending, at least 2 knots (2 knots: a straight line, z'' = 0)."""
    y = np.asarray(y_m, dtype=np.float64)
    z = np.asarray(z_m, dtype=np.float64)
    n = y.size
    m = np.zeros(n)
    if n < 3:
        return m
    h = np.diff(y)
    # tridiagonal system for the interior z''_1 .. z''_{n-2} (Thomas algorithm)
    a = h[:-1].copy()  # sub-diagonal
    b = 2.0 * (h[:-1] + h[1:])  # diagonal
    c = h[1:].copy()  # super-diagonal
    d = 6.0 * ((z[2:] - z[1:-1]) / h[1:] - (z[1:-1] - z[:-2]) / h[:-1])
    k = n - 2
    for i in range(1, k):
        w = a[i] / b[i - 1]
        b[i] -= w * c[i - 1]
        d[i] -= w * d[i - 1]
    x = np.empty(k)
    x[-1] = d[-1] / b[-1]
    for i in range(k - 2, -1, -1):
        x[i] = (d[i] - c[i] * x[i + 1]) / b[i]
    m[1:-1] = x
    return m


def spline_slope(
    y_m: NDArray[np.float64],
    z_m: NDArray[np.float64],
    m: NDArray[np.float64],
    yq: NDArray[np.float64],
) -> NDArray[np.float64]:
    """dz/dy of the spline (knots y, heights z, second derivatives m) at the points yq (NumPy
    twin of ``dynamics.profile_slope``)."""
    y = np.asarray(y_m, dtype=np.float64)
    z = np.asarray(z_m, dtype=np.float64)
    q = np.asarray(yq, dtype=np.float64)
    i = np.clip(np.searchsorted(y, q, side="right") - 1, 0, y.size - 2)
    t = np.clip(q, y[0], y[-1]) - y[i]
    h = y[i + 1] - y[i]
    return (
        (z[i + 1] - z[i]) / h
        - h * (2.0 * m[i] + m[i + 1]) / 6.0
        + m[i] * t
        + (m[i + 1] - m[i]) * t * t / (2.0 * h)
    )


def max_abs_slope(
    cross_slope: float, y_m: NDArray[np.float64] | None, z_m: NDArray[np.float64] | None
) -> tuple[float, float]:
    """(max |dz/dy|, the y (m) where it is) of the cross slope plus the profile's spline (the
    spline's slope is quadratic between knots: its extremes are at knots or at the vertex of
    the quadratic). Without a profile the y is NaN."""
    if y_m is None or z_m is None:
        return abs(cross_slope), float("nan")
    y = np.asarray(y_m, dtype=np.float64)
    z = np.asarray(z_m, dtype=np.float64)
    m = natural_spline(y, z)
    cand = [y]
    dm = np.diff(m)
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = -m[:-1] * np.diff(y) / dm  # where the slope's derivative m(t) is zero
    ok = np.isfinite(tv) & (tv > 0.0) & (tv < np.diff(y))
    cand.append(y[:-1][ok] + tv[ok])
    pts = np.concatenate(cand)
    s = np.abs(cross_slope + spline_slope(y, z, m, pts))
    j = int(np.argmax(s))
    return float(s[j]), float(pts[j])
