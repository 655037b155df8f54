"""benchmarks/rk_pair.py's variant: the shipped ``core/tsit5.py`` with only the pair swapped.
(The order conditions of both pairs: tests/test_tsit5.py.)"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from helpers.runge_kutta import names_of

from benchmarks.rk_pair import DP5_CONSTANTS, PAIR_END, dp5_module

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = (ROOT / "bowlrec" / "core" / "tsit5.py").read_text()


def _pair_block(module: str) -> str:
    start = module.index("# --- the pair")
    return module[start : module.index(PAIR_END)]


def test_the_variant_module_swaps_only_the_pair() -> None:
    variant = dp5_module(SHIPPED)
    assert variant.replace(_pair_block(variant), "") == SHIPPED.replace(_pair_block(SHIPPED), "")
    defined = {n.name for n in ast.parse(variant).body if isinstance(n, ast.FunctionDef)}
    kept = {n.name for n in ast.parse(SHIPPED).body if isinstance(n, ast.FunctionDef)}
    assert defined == kept  # the kernel's imports find every function
    assert "19372.0 / 6561.0" in variant and "0.161" not in variant


def test_the_variant_defines_every_name_the_pair_block_does() -> None:
    shipped = set(names_of(_pair_block(SHIPPED)))
    assert shipped <= set(names_of(DP5_CONSTANTS))


def test_a_changed_module_is_refused() -> None:
    with pytest.raises(RuntimeError, match="pair's block"):
        dp5_module(SHIPPED.replace(PAIR_END, "# the pair ends here"))
