"""Small fixed-size vector, matrix and quaternion helpers for the compiled kernels.

Everything works on scalars and tuples (no array allocation), so the kernels stay allocation-free.
Quaternions are (w, x, y, z) and rotate body-frame vectors into the lane frame.
"""

from __future__ import annotations

from typing import Any

from numba import njit

from ._kernel_cache import check_core

check_core()  # drops stale kernel caches first

#: numba options of the kernels' helper functions, which allocate nothing: no reference counting
#: (numba's atomic increments/decrements of their array arguments cost a large share of the
#: kernels' run time). ``_nrt`` is a numba-internal target option (used by numba itself, present
#: in every numba version bowlrec supports); a helper compiled with it must not create or return
#: arrays.
NO_NRT: dict[str, Any] = {"_nrt": False}


@njit(cache=True, error_model="numpy", forceinline=True)
def cross(ax, ay, az, bx, by, bz):  # type: ignore[no-untyped-def]
    """a x b as a tuple."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True, error_model="numpy", forceinline=True)
def quat_matrix(qw, qx, qy, qz):  # type: ignore[no-untyped-def]
    """Rotation matrix (row-major 9-tuple) of the quaternion, normalized first.

    Written with s = 2 / |q|^2 (one division, no square root) so the division overlaps with the
    products instead of preceding them."""
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    xx = qx * qx
    yy = qy * qy
    zz = qz * qz
    xy = qx * qy
    xz = qx * qz
    yz = qy * qz
    wx = qw * qx
    wy = qw * qy
    wz = qw * qz
    return (
        1.0 - s * (yy + zz),
        s * (xy - wz),
        s * (xz + wy),
        s * (xy + wz),
        1.0 - s * (xx + zz),
        s * (yz - wx),
        s * (xz - wy),
        s * (yz + wx),
        1.0 - s * (xx + yy),
    )


@njit(cache=True, error_model="numpy", forceinline=True)
def world_inertia(m, k1, k2, k3):  # type: ignore[no-untyped-def]
    """R diag(k) R^T as a symmetric 6-tuple (xx, yy, zz, xy, xz, yz)."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = m
    ixx = r00 * r00 * k1 + r01 * r01 * k2 + r02 * r02 * k3
    iyy = r10 * r10 * k1 + r11 * r11 * k2 + r12 * r12 * k3
    izz = r20 * r20 * k1 + r21 * r21 * k2 + r22 * r22 * k3
    ixy = r00 * r10 * k1 + r01 * r11 * k2 + r02 * r12 * k3
    ixz = r00 * r20 * k1 + r01 * r21 * k2 + r02 * r22 * k3
    iyz = r10 * r20 * k1 + r11 * r21 * k2 + r12 * r22 * k3
    return ixx, iyy, izz, ixy, ixz, iyz


@njit(cache=True, error_model="numpy", forceinline=True)
def rotate(m, bx, by, bz):  # type: ignore[no-untyped-def]
    """R b for a row-major 9-tuple R."""
    return (
        m[0] * bx + m[1] * by + m[2] * bz,
        m[3] * bx + m[4] * by + m[5] * bz,
        m[6] * bx + m[7] * by + m[8] * bz,
    )


@njit(cache=True, error_model="numpy", forceinline=True)
def solve3(a00, a01, a02, a10, a11, a12, a20, a21, a22, b0, b1, b2):  # type: ignore[no-untyped-def]
    """Solve the 3x3 system A x = b by the adjugate (A is well conditioned here)."""
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    det = a00 * c00 + a01 * c01 + a02 * c02
    c10 = a02 * a21 - a01 * a22
    c11 = a00 * a22 - a02 * a20
    c12 = a01 * a20 - a00 * a21
    c20 = a01 * a12 - a02 * a11
    c21 = a02 * a10 - a00 * a12
    c22 = a00 * a11 - a01 * a10
    inv = 1.0 / det
    x0 = (c00 * b0 + c10 * b1 + c20 * b2) * inv
    x1 = (c01 * b0 + c11 * b1 + c21 * b2) * inv
    x2 = (c02 * b0 + c12 * b1 + c22 * b2) * inv
    return x0, x1, x2
