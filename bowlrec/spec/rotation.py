"""Small rotation helpers (NumPy, dimensionless): frames from axes, matrix <-> quaternion.

Quaternions are (w, x, y, z) and rotate body vectors into the lane frame.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "frame_from_axes",
    "matrix_to_quaternion",
    "normalized",
    "perpendicular",
    "quaternion_to_matrix",
]

Array = NDArray[np.float64]
#: components between these square without overflow or underflow (float64)
_SAFE_MIN, _SAFE_MAX = 1e-150, 1e150


def _norm(a: Array) -> np.float64:
    """|a| of a float64 vector, computed as ``np.linalg.norm`` computes it (the square root of
    ``a.dot(a)``: the same bits) without its argument handling, which costs several times more
    for a 3-vector."""
    return np.sqrt(a.dot(a))  # type: ignore[no-any-return]


def _cross(a: Array, b: Array) -> Array:
    """a x b of two float64 3-vectors: each component one product minus another, rounded as
    ``np.cross`` rounds them (the same bits), without its array set-up."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def normalized(v: Sequence[float] | Array) -> Array:
    """``v / |v|`` as float64 (the caller guarantees |v| > 0). A vector whose largest
    component is beyond 1e150 or below 1e-150 in magnitude is first divided by it, so that
    squaring the components neither overflows nor underflows (any finite direction works)."""
    a = np.asarray(v, dtype=np.float64)
    largest = float(np.max(np.abs(a)))
    if not _SAFE_MIN < largest < _SAFE_MAX:
        a = a / largest
    return a / _norm(a)


def perpendicular(a: Sequence[float] | Array) -> Array:
    """A unit vector perpendicular to ``a``, chosen deterministically: the lane basis vector
    least aligned with ``a`` (first one on ties), with its component along ``a`` removed."""
    u = normalized(a)
    e = np.zeros(3)
    e[int(np.argmin(np.abs(u)))] = 1.0
    return normalized(e - np.dot(e, u) * u)


def frame_from_axes(
    axis_1: Sequence[float] | Array, axis_2: Sequence[float] | Array | None = None
) -> Array:
    """Rotation matrix (body -> lane) whose columns are the unit principal axes 1, 2, 3.

    ``axis_2`` is made exactly perpendicular to ``axis_1`` (Gram-Schmidt); if None, see
    :func:`perpendicular`. Axis 3 = axis 1 x axis 2 (right-handed).
    """
    a1 = normalized(axis_1)
    if axis_2 is None:
        a2 = perpendicular(a1)
    else:
        b = np.asarray(axis_2, dtype=np.float64)
        a2 = normalized(b - np.dot(b, a1) * a1)
    a3 = _cross(a1, a2)
    return np.column_stack([a1, a2, a3 / _norm(a3)])


def matrix_to_quaternion(r: Array) -> Array:
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (Shepperd's method: divide by
    the largest of the four candidate components, so it is accurate for every rotation)."""
    m = np.asarray(r, dtype=np.float64)
    t = m[0, 0] + m[1, 1] + m[2, 2]
    k = int(np.argmax([t, m[0, 0], m[1, 1], m[2, 2]]))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 - m[0, 0] + m[1, 1] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 - m[0, 0] - m[1, 1] + m[2, 2])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    qa = normalized(q)
    return -qa if qa[0] < 0.0 else qa


def quaternion_to_matrix(q: Sequence[float] | Array) -> Array:
    """Rotation matrix (body -> lane) of a quaternion (w, x, y, z); normalizes it first."""
    w, x, y, z = normalized(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
