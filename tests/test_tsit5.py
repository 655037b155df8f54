"""The Runge-Kutta pair of ``bowlrec/core/tsit5.py`` against Butcher's order conditions.

Tsitouras' coefficients are decimals (16-17 digits), so each condition holds to rounding only:
measured 1.0e-14 at most, against 4e-16 for Dormand-Prince's exact rationals; the tolerance is
1e-13. Dormand-Prince's pair (``benchmarks/rk_pair.py``'s variant) passing the same checks shows
the checker itself is right, and one coefficient changed by 1e-6 relative fails them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest
from helpers.runge_kutta import extension, names_of, residuals, tableau

import bowlrec.core.tsit5 as tsit5
from benchmarks.rk_pair import DP5_CONSTANTS
from bowlrec.core.codes import N_STATE

TOL = 1e-13


def _pairs() -> dict[str, Mapping[str, float]]:
    shipped = {k: float(v) for k, v in vars(tsit5).items() if isinstance(v, float)}
    return {"tsitouras": shipped, "dormand-prince": names_of(DP5_CONSTANTS)}


PAIRS = _pairs()


@pytest.mark.parametrize("name", PAIRS)
def test_the_solution_is_fifth_order_and_the_embedded_one_fourth(name: str) -> None:
    """All 17 conditions up to order 5 for b; up to order 4 for b_hat, which must fail some of
    order 5 (otherwise the error estimate would be of a higher order than it says)."""
    a, b, b_hat, c = tableau(PAIRS[name])
    assert max(abs(r) for r in residuals(a, c, b, 5)) < TOL
    assert max(abs(r) for r in residuals(a, c, b_hat, 4)) < TOL
    assert max(abs(r) for r in residuals(a, c, b_hat, 5)) > 1e-5
    assert c[-1] == pytest.approx(1.0, abs=TOL) and c[-2] == pytest.approx(1.0, abs=TOL)


@pytest.mark.parametrize("name", PAIRS)
@pytest.mark.parametrize("theta", [0.0, 0.1, 0.37, 0.5, 0.81, 1.0])
def test_the_continuous_extension_is_fourth_order_and_ends_at_the_solution(
    name: str, theta: float
) -> None:
    a, b, _, c = tableau(PAIRS[name])
    weights = extension(PAIRS[name], theta)
    assert max(abs(r) for r in residuals(a, c, weights, 4, theta)) < TOL
    if theta == 1.0:
        np.testing.assert_allclose(weights, b, rtol=0, atol=TOL)


def test_a_changed_digit_fails_the_conditions() -> None:
    """The checks can fail: a75 off by 1e-6 relative breaks the order-5 conditions."""
    bent = dict(PAIRS["tsitouras"], A75=PAIRS["tsitouras"]["A75"] * (1 + 1e-6))
    a, b, _, c = tableau(bent)
    assert max(abs(r) for r in residuals(a, c, b, 5)) > 1e-7


def test_the_kernels_dense_output_is_the_extension() -> None:
    """``dense_coeffs`` and ``dense`` (the form through both ends of the step) give
    y + h sum b_i(theta) K_i for arbitrary stages, to rounding."""
    rng = np.random.default_rng(7)
    y = rng.normal(size=N_STATE)
    stages = rng.normal(size=(7, N_STATE))
    h = 0.003
    _, b, _, _ = tableau(PAIRS["tsitouras"])
    ynew = y + h * (b @ stages)
    rc = np.empty((5, N_STATE))
    out = np.empty(N_STATE)
    tsit5.dense_coeffs(y, ynew, stages, h, rc)
    for theta in (0.0, 0.25, 0.6, 1.0):
        tsit5.dense(rc, theta, out)
        expected = y + h * (extension(PAIRS["tsitouras"], theta) @ stages)
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-15)
    tsit5.dense(rc, 1.0, out)
    np.testing.assert_array_equal(out, y + (ynew - y))
