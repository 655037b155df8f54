"""Shortcuts for what a scene doesn't need, each checked against the full model where both apply."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bowlrec.core.arguments import (
    ORIENTATION_GAIN,
    needs_orientation,
    orientation_weight,
    use_closed_form,
)
from bowlrec.core.batch import EVENT_CAP, batch_metrics, pack_plans, run_batch
from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.plan import Plan
from bowlrec.core.solver import solve
from bowlrec.paper import paper_scene
from bowlrec.spec import Scene

UNIFORM_CASES = [1, 6, 7, 8, 9, 13]


def _uniform(
    friction: dict, omega: tuple[float, float, float], angle: float, y0: float | None = None
) -> Plan:
    scene = Scene.model_validate(
        {
            "ball": {"rg_m": [0.064, 0.064, 0.064]},
            "lane": {"friction": friction},
            "delivery": {
                "omega_radps": omega,
                "takeoff_angle_deg": angle,
                "position_m": None if y0 is None else [0.0, y0],
            },
            "options": {"record": "summary", "rtol": 1e-12},
        }
    )
    return scene.resolve()


ZONES = {
    "kind": "zones",
    "default_mu": 0.18,
    "zones": [
        {"x_min_m": -1, "x_max_m": 9.0, "y_min_m": 0.2, "y_max_m": 0.85, "mu": 0.03},
        {"x_min_m": 9.0, "x_max_m": 13.0, "y_min_m": 0.3, "y_max_m": 0.75, "mu": 0.06},
    ],
}

CLOSED_FORM_SCENES = {
    **{
        f"paper-{c}": replace(paper_scene(c).resolve(), record_mode=RECORD_SUMMARY, rtol=1e-12)
        for c in UNIFORM_CASES
    },
    "zones-hook": _uniform(ZONES, (-25.0, 15.0, 3.0), -2.0),
    "zones-gutter": _uniform(ZONES, (-5.0, 25.0, 0.0), -4.0, 0.25),
    "backspin-stops": _uniform({"kind": "constant", "mu": 0.25}, (0.0, -120.0, 0.0), 0.0),
    "on-oil-edge": _uniform({"kind": "typical"}, (-30.0, 0.0, 0.0), -2.0, 0.10668),
}


@pytest.mark.parametrize("name", sorted(CLOSED_FORM_SCENES))
def test_closed_form_agrees_with_the_integrator(name: str) -> None:
    plan = CLOSED_FORM_SCENES[name]
    assert use_closed_form(plan)
    exact_run = solve(plan, "closed_form")
    numeric_run = solve(plan, "integrator")
    exact = exact_run.summary
    numeric = numeric_run.summary
    assert exact.n_rhs == 0 and numeric.n_rhs > 0
    assert exact.outcome == numeric.outcome
    for field in ("slide_m", "hook_m", "pocket_deg", "time_s", "x_end_m", "y_end_m"):
        a = getattr(exact, field)
        b = getattr(numeric, field)
        if a is None or b is None:
            assert a is b, field
        else:
            assert a == pytest.approx(b, rel=1e-9, abs=1e-9), field
    # same events (a release exactly on a boundary is a zero-time zone event for the integrator)
    a_events = [e for e in exact_run.events if e.t_s > 1e-12]
    b_events = [e for e in numeric_run.events if e.t_s > 1e-12]
    assert [e.kind for e in a_events] == [e.kind for e in b_events]
    for ea, eb in zip(a_events, b_events, strict=True):
        assert ea.t_s == pytest.approx(eb.t_s, rel=1e-9)
        assert ea.x_m == pytest.approx(eb.x_m, rel=1e-9)
        assert ea.mu == eb.mu


def test_default_solve_picks_the_closed_form_only_where_it_applies() -> None:
    assert solve(CLOSED_FORM_SCENES["paper-7"]).summary.n_rhs == 0
    nonuniform = replace(paper_scene(10).resolve(), record_mode=RECORD_SUMMARY)
    assert not use_closed_form(nonuniform)
    assert solve(nonuniform).summary.n_rhs > 0
    recorded = paper_scene(7).resolve()  # records samples: integrator
    assert not use_closed_form(recorded)


def _nearly_uniform(plan: Plan) -> Plan:
    """``plan`` with a centered ball whose principal moments differ by 1e-5 relative."""
    k = np.asarray(plan.inertia_per_mass_m2).mean() * np.array([1.0, 1.0, 1.0 + 1e-5])
    return replace(plan, inertia_per_mass_m2=k, r_delta_body_m=np.zeros(3))


def test_orientation_is_integrated_only_when_something_depends_on_it() -> None:
    uniform = CLOSED_FORM_SCENES["paper-1"]
    assert not needs_orientation(uniform)
    assert orientation_weight(uniform) == 0.0
    assert needs_orientation(paper_scene(1).resolve())  # samples recorded: orientation output
    nonuniform = replace(paper_scene(16).resolve(), record_mode=RECORD_SUMMARY)
    assert needs_orientation(nonuniform)
    # Table III case 16 (RG 2.46 / 2.60 in): any real ball gets the full weight
    k = np.asarray(nonuniform.inertia_per_mass_m2)
    influence = (k.max() - k.min()) / k.mean()
    assert ORIENTATION_GAIN * influence > 1.0
    assert orientation_weight(nonuniform) == 1.0
    # a nearly uniform ball is weighted by ORIENTATION_GAIN times its relative influence
    nearly = _nearly_uniform(nonuniform)
    k_near = nearly.inertia_per_mass_m2
    tiny = (k_near.max() - k_near.min()) / k_near.mean()
    assert orientation_weight(nearly) == pytest.approx(ORIENTATION_GAIN * tiny)
    assert 0.0 < orientation_weight(nearly) < 1.0


def test_summary_only_weighting_of_the_orientation_keeps_the_metrics() -> None:
    # recorded (full orientation weight) and summary-only runs agree at the default tolerance to
    # well below the convergence criterion (0.1 mm, 0.001 deg). Table III's balls get the full
    # weight in both (ORIENTATION_GAIN); the nearly uniform ball is weighted below 1 when only
    # the summary is asked for.
    nearly = _nearly_uniform(paper_scene(16).resolve())
    assert orientation_weight(replace(nearly, record_mode=RECORD_SUMMARY)) < 1.0
    for plan in [paper_scene(case).resolve() for case in (5, 12, 16, 18)] + [nearly]:
        full = solve(plan).summary
        fast = solve(replace(plan, record_mode=RECORD_SUMMARY)).summary
        assert fast.hook_m == pytest.approx(full.hook_m, abs=1e-5)
        assert fast.pocket_deg == pytest.approx(full.pocket_deg, abs=1e-4)


@pytest.mark.parametrize("parallel", [False, True])
def test_batch_equals_one_by_one(parallel: bool) -> None:
    """The many-delivery kernel and solve() give the same summary, bit for bit: one summary
    computation serves both (bowlrec.core.summary), including the slide of a ball released
    rolling (its release x) and the events the batch keeps."""
    plans = [replace(paper_scene(c).resolve(), record_mode=RECORD_SUMMARY) for c in range(1, 19)]
    plans += list(CLOSED_FORM_SCENES.values())
    rolling = Scene.model_validate(
        {"delivery": {"speed_mps": 0.1085 * 60.0, "omega_radps": [0.0, 60.0, 0.0]}}
    ).resolve()
    plans.append(replace(rolling, record_mode=RECORD_SUMMARY))
    packed = pack_plans(plans)
    result = run_batch(packed, parallel=parallel)
    metrics = batch_metrics(packed, result)
    for i, plan in enumerate(plans):
        traj = solve(plan)
        s = traj.summary.to_dict()
        for k, v in s.items():
            if k == "message":
                continue
            got = metrics[k][i]
            if v is None:
                assert np.isnan(got), (i, k)
            else:
                assert got == v, (i, k, got, v)
        kept = result.events[i, : min(EVENT_CAP, result.n_events[i])]
        assert [e.t_s for e in traj.events][:EVENT_CAP] == list(kept[:, 0])
    assert metrics["slide_m"][-1] == 0.0  # released rolling: no slide, not "never rolls"
