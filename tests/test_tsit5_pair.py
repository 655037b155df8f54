"""The Tsitouras pair of benchmarks/tsit5_pair.py: its coefficients are consistent and the
variant of core/dopri5.py it writes is the current module with only the pair swapped."""

from __future__ import annotations

import ast
import math
from pathlib import Path

from benchmarks.tsit5_pair import TSIT5_CONSTANTS, tsit5_module

ROOT = Path(__file__).resolve().parents[1]


def _constants() -> dict[str, float]:
    names: dict[str, float] = {}
    exec(TSIT5_CONSTANTS, {}, names)  # noqa: S102 - the benchmark's own constant block
    return names


def test_the_pair_is_consistent() -> None:
    """The solution's weights (the last stage row, first same as last) sum to 1, the error
    weights (b - b_hat) to 0, the continuous extension ends at the solution (b_i(1) = b_i) and
    starts with slope f(y0) (b_i'(0) = 1 for stage 1 only), and each stage row sums to its
    node (c_7 = 1)."""
    k = _constants()
    b = [k["A71"], k["A72"], k["A73"], k["A74"], k["A75"], k["A76"], 0.0]
    assert math.isclose(sum(b), 1.0, abs_tol=1e-14)
    assert abs(sum(k[f"E{i}"] for i in range(1, 8))) < 1e-14
    theta1 = [k["R11"] + k["R12"] + k["R13"] + k["R14"]] + [
        k[f"R{i}2"] + k[f"R{i}3"] + k[f"R{i}4"] for i in range(2, 8)
    ]
    assert all(math.isclose(a, c, abs_tol=1e-14) for a, c in zip(theta1, b, strict=True))
    assert k["R11"] == 1.0
    rows = {2: [k["A21"]], 3: [k["A31"], k["A32"]], 4: [k["A41"], k["A42"], k["A43"]]}
    nodes = {2: 0.161, 3: 0.327, 4: 0.9}
    for i, row in rows.items():
        assert math.isclose(sum(row), nodes[i], abs_tol=1e-14), i


def test_the_variant_module_swaps_only_the_pair() -> None:
    original = (ROOT / "bowlrec" / "core" / "dopri5.py").read_text()
    variant = tsit5_module(original)
    tree = ast.parse(variant)
    defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    kept = {n.name for n in ast.parse(original).body if isinstance(n, ast.FunctionDef)}
    assert defined == kept  # the kernel's imports find every function
    assert "A72 * K[1, i]" in variant and "E2 * K[1, i]" in variant
    assert "C2, C3, C4, C5" not in variant and "D1 * K[0, i]" not in variant
