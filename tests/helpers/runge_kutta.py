"""Order conditions of an explicit 7-stage Runge-Kutta pair with a continuous extension.

A pair is read from the names ``bowlrec/core/tsit5.py`` uses: stage rows ``Aij``, the
solution's weights ``A7j`` (first same as last), error weights ``Ei`` (b - b_hat) and the
continuous extension's coefficients ``Ri2..Ri4`` (b_i(theta) = [i = 1] theta + Ri2 theta^2 +
Ri3 theta^3 + Ri4 theta^4). The conditions are Butcher's: sum_i b_i Phi_i(t) = 1 / gamma(t) for
every rooted tree t up to the order (Hairer, Norsett and Wanner, "Solving Ordinary Differential
Equations I", Sec. II.2, Table 2.2), and theta^|t| / gamma(t) for the continuous extension.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

Vector = NDArray[np.float64]

N_STAGES = 7


def tableau(k: Mapping[str, float]) -> tuple[NDArray[np.float64], Vector, Vector, Vector]:
    """(A, b, b_hat, c) of the pair named in ``k``."""
    a = np.zeros((N_STAGES, N_STAGES))
    for i in range(2, N_STAGES + 1):
        for j in range(1, i):
            a[i - 1, j - 1] = k[f"A{i}{j}"]
    b = a[N_STAGES - 1].copy()
    e = np.array([k[f"E{i}"] for i in range(1, N_STAGES + 1)])
    return a, b, b - e, a.sum(axis=1)


def extension(k: Mapping[str, float], theta: float) -> Vector:
    """The continuous extension's weights b_i(theta)."""
    first = np.array([1.0] + [0.0] * (N_STAGES - 1))
    powers = [k[f"R{i}{p}"] for i in range(1, N_STAGES + 1) for p in (2, 3, 4)]
    r = np.array(powers).reshape(N_STAGES, 3)
    return np.asarray(first * theta + r @ np.array([theta**2, theta**3, theta**4]))


def _trees(a: NDArray[np.float64], c: Vector) -> list[tuple[int, float, Vector]]:
    """(order, gamma, Phi) of the 17 rooted trees up to order 5."""
    ac = a @ c
    return [
        (1, 1.0, np.ones_like(c)),
        (2, 2.0, c),
        (3, 3.0, c**2),
        (3, 6.0, ac),
        (4, 4.0, c**3),
        (4, 8.0, c * ac),
        (4, 12.0, a @ c**2),
        (4, 24.0, a @ ac),
        (5, 5.0, c**4),
        (5, 10.0, c**2 * ac),
        (5, 20.0, ac**2),
        (5, 15.0, c * (a @ c**2)),
        (5, 30.0, c * (a @ ac)),
        (5, 20.0, a @ c**3),
        (5, 40.0, a @ (c * ac)),
        (5, 60.0, a @ (a @ c**2)),
        (5, 120.0, a @ (a @ ac)),
    ]


def residuals(
    a: NDArray[np.float64], c: Vector, weights: Vector, order: int, theta: float = 1.0
) -> list[float]:
    """sum_i w_i Phi_i(t) - theta^|t| / gamma(t) for every tree of at most ``order`` nodes."""
    return [float(weights @ phi - theta**n / gamma) for n, gamma, phi in _trees(a, c) if n <= order]


def names_of(block: str) -> dict[str, float]:
    """The float constants a block of Python assignments defines."""
    names: dict[str, object] = {}
    exec(block, {}, names)  # noqa: S102 - a constant block of this repository
    return {k: float(v) for k, v in names.items() if isinstance(v, float)}
