"""The Magnus lift's spin parameter S on a real delivery, and the lift coefficient outside the
range of its data (docs/lane-and-air.md, "The spin parameter of a bowling ball" and "What the
model does outside the range"; numbers in benchmarks/results/magnus_spin.md).

S is computed here from the state alone, as R |w_perp| / |v| with w_perp = w minus its part
along v (not through w x v, as the kernel and the benchmark do), and the S the kernel uses is
read back from the lift it applies: |e_L| = k_L C_L(S) |v|^2 with k_L = rho pi R^2 / (2 M),
inverted through C_L = 0.09 + 0.6 S (S > 0.1 along the whole delivery).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmarks.magnus_spin import spin_parameter
from bowlrec.core.arguments import kernel_params
from bowlrec.core.codes import LIFT_SAWICKI
from bowlrec.core.dynamics import external_accel, lift_coefficient_per_spin
from bowlrec.core.solver import solve
from bowlrec.core.trajectory import Trajectory
from bowlrec.scene_input import parse_scene_file

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "lane-and-air.md"
RESULTS = ROOT / "benchmarks" / "results" / "magnus_spin.json"
EXAMPLE = "examples/bowler/pocket-right.json"


def _cl(s: float) -> float:
    return s * lift_coefficient_per_spin(s, LIFT_SAWICKI)


def _docs() -> str:
    return " ".join(DOCS.read_text(encoding="utf-8").split())


@pytest.fixture(scope="module")
def delivery() -> tuple[Any, Trajectory]:
    """The pocket-right example with Magnus lift on: its plan and recorded trajectory."""
    plan = dataclasses.replace(
        parse_scene_file(ROOT / EXAMPLE).scene.resolve(), lift_model=LIFT_SAWICKI
    )
    return plan, solve(plan)


def _independent_s(radius: float, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    speed = np.linalg.norm(v, axis=1)
    along = np.sum(w * v, axis=1) / speed
    w_perp = w - along[:, None] * v / speed[:, None]
    return np.asarray(radius * np.linalg.norm(w_perp, axis=1) / speed)


def test_spin_parameter_is_r_omega_perp_over_v(delivery: tuple[Any, Trajectory]) -> None:
    """The benchmark's S and the S the kernel's lift uses both equal R |w_perp| / |v| at every
    sample of the delivery (1e-12 and 1e-9 relative: the second goes through the force)."""
    plan, tr = delivery
    r = plan.radius_m
    v, w = tr.velocity_mps, tr.omega_radps
    s = _independent_s(r, v, w)
    assert tr.n_samples > 100 and s.min() > 0.1
    np.testing.assert_allclose(spin_parameter(r, v, w), s, rtol=1e-12)

    par = kernel_params(plan)
    k_l = 0.5 * plan.air_density_kg_m3 * math.pi * r * r / plan.mass_kg
    used = np.empty(tr.n_samples)
    for i in range(tr.n_samples):
        y = np.concatenate(
            [tr.position_m[i, :2], v[i, :2], tr.quaternion_wxyz[i], tr.omega_radps[i]]
        )
        e = np.array(external_accel(y, par)[:3])
        v2 = float(v[i] @ v[i])
        used[i] = (np.linalg.norm(e) / (k_l * v2) - 0.09) / 0.6
        # along w x v
        wxv = np.cross(w[i], v[i])
        assert e @ wxv / (np.linalg.norm(e) * np.linalg.norm(wxv)) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(used, s, rtol=1e-9)


def test_rolling_ball_has_s_of_at_least_one(delivery: tuple[Any, Trajectory]) -> None:
    """Rolling, the contact point is at rest (v = R (w_y, -w_x)), so
    S = sqrt(1 + (R w_z / |v|)^2) >= 1; sliding after release, S is far below 1."""
    plan, tr = delivery
    r = plan.radius_m
    s = _independent_s(r, tr.velocity_mps, tr.omega_radps)
    rolling = tr.phase == 1
    assert rolling.any() and (~rolling).any()
    speed = np.linalg.norm(tr.velocity_mps[rolling], axis=1)
    expected = np.sqrt(1.0 + (r * tr.omega_radps[rolling, 2] / speed) ** 2)
    np.testing.assert_allclose(s[rolling], expected, rtol=1e-8)
    assert s[rolling].min() >= 1.0 - 1e-8
    assert s[0] < 0.4


def test_committed_results_are_what_the_code_computes(delivery: tuple[Any, Trajectory]) -> None:
    """benchmarks/results/magnus_spin.json's S at release, at the start of rolling and at the
    pins for this example are the ones computed here."""
    plan, tr = delivery
    doc = json.loads(RESULTS.read_text(encoding="utf-8"))
    row = next(r for r in doc["deliveries"] if r["name"] == Path(EXAMPLE).stem)
    s = _independent_s(plan.radius_m, tr.velocity_mps, tr.omega_radps)
    i_roll = int(np.argmax(tr.phase == 1))
    assert row["s_release"] == pytest.approx(s[0], rel=1e-12)
    assert row["s_roll_start"] == pytest.approx(s[i_roll], rel=1e-9)
    assert row["s_pins"] == pytest.approx(s[-1], rel=1e-9)
    assert row["s_max"] == pytest.approx(s.max(), rel=1e-9)


def test_lift_coefficient_outside_the_data_range() -> None:
    """Above S = 0.6 the model continues C_L = 0.09 + 0.6 S without a cap (C_L(1.0) = 0.69, as
    the docs state); below 0.1 it is 1.5 S."""
    assert _cl(0.6) == pytest.approx(0.45, abs=1e-15)
    assert _cl(1.0) == pytest.approx(0.69, abs=1e-15)
    for s in (0.6, 0.8, 1.0, 1.03, 2.0, 10.0):
        assert _cl(s) == pytest.approx(0.09 + 0.6 * s, rel=1e-15)
    # linear, slope 0.6, all the way up: no saturation
    assert (_cl(10.0) - _cl(1.0)) / 9.0 == pytest.approx(0.6, rel=1e-13)
    assert _cl(0.05) == pytest.approx(0.075, abs=1e-15)
    m = re.search(r"continues linearly \(C_L\(1\.0\) = ([\d.]+), growing without bound", _docs())
    assert m is not None, "docs/lane-and-air.md: the extrapolation's sentence is gone"
    assert float(m.group(1)) == pytest.approx(_cl(1.0), abs=5e-3)


def test_docs_state_the_measured_spin_parameters() -> None:
    """docs/lane-and-air.md's ranges of S are the committed benchmark's, to their rounding."""
    doc = json.loads(RESULTS.read_text(encoding="utf-8"))
    rows = doc["deliveries"]
    ex = [r for r in rows if r["aim"] == "as written"]
    grid = [r for r in rows if r["aim"] != "as written"]
    text = _docs()

    def said(pattern: str) -> tuple[float, float]:
        m = re.search(pattern, text)
        assert m is not None, f"docs/lane-and-air.md: no match for {pattern!r}"
        return float(m.group(1)), float(m.group(2))

    def span(key: str, sel: list[dict[str, Any]]) -> tuple[float, float]:
        vals = [r[key] for r in sel if r[key] is not None]
        return round(min(vals), 2), round(max(vals), 2)

    assert said(r"the example scenes have S = ([\d.]+)-([\d.]+)") == span("s_release", ex)
    assert said(r"the nine deliveries ([\d.]+)-([\d.]+) \(more revs") == span("s_release", grid)
    assert len(grid) == 9
    lo, hi = said(r">= 1, ([\d.]+)-([\d.]+) from the start of rolling")
    rolling = [v for r in rows for v in (r["s_min_rolling"], r["s_roll_start"]) if v is not None]
    assert (lo, hi) == (round(min(rolling), 2), round(max(r["s_max"] for r in rows), 2))
    in_range = [r for r in rows if r["s_release"] <= 0.6]
    assert said(r"released below S = 0\.6, (\d+)-(\d+) % of it comes from") == tuple(
        round(100 * x) for x in span("share_from_above_range", in_range)
    )
    m = re.search(r"changes it by at most (\d+) %", text)
    assert m is not None
    assert int(m.group(1)) == round(100 * (1 - min(r["held_over_linear"] for r in in_range)))
