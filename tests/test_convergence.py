"""Summary metrics at the default tolerance agree with a 100x tighter run on all 18 cases, and
where the exact answer is known (the uniform-ball cases: the closed form) the integrator at the
default tolerance reproduces it.

The tolerances are a small factor above what is measured, so that a real loss of accuracy fails
(a looser default rtol, a wrong Runge-Kutta coefficient, an event located late), not only a
gross one. Measured at the default rtol 1e-9 over the 12 cases that integrate (Table III cases
2-5, 10-12, 14-18), largest |default - rtol/100| differences:

=========  ==========  ======================  =========
quantity   measured    case                    tolerance
=========  ==========  ======================  =========
hook       6.6e-11 m   12                      3e-9 m
pocket     1.6e-9 deg  16                      1e-7 deg
slide      2.0e-8 m    5                       1e-6 m
time       1.5e-11 s   2                       1e-9 s
=========  ==========  ======================  =========

(factors 45-66; the metrics differ between platforms by ~1e-9 relative, ~2e-8 m of a 16 m
slide, so the slide's is not tighter). For comparison, a default rtol of 1e-8 (10x looser)
gives 1.3e-8 m of hook and 6.1e-6 m of slide (cases 18 and 5) and fails, where tolerances of
0.1 mm, 0.001 deg and 1 us would pass even a default rtol of 1e-7 (100x looser: 3.6e-5 m of
slide, 2.2e-7 deg). The six uniform-ball cases (1, 6-9, 13) run the closed
form (``solve`` picks it), so comparing two tolerances there compares the closed form with itself;
they instead compare the integrator at the default rtol with the closed form: measured 2.1e-14
(m, deg, s), tolerance 1e-12 (the motion is piecewise polynomial, which a 5th-order pair integrates
exactly, so only the location of the events and rounding remain).
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from bowlrec.core.arguments import use_closed_form
from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.solver import solve
from bowlrec.core.trajectory import Summary
from bowlrec.paper import paper_scene
from bowlrec.spec import Options

UNIFORM = (1, 6, 7, 8, 9, 13)
INTEGRATED = tuple(c for c in range(1, 19) if c not in UNIFORM)

#: default rtol against rtol / 100 (module docstring: measured 6.6e-11 m, 1.6e-9 deg, 2.0e-8 m,
#: 1.5e-11 s)
HOOK_M, POCKET_DEG, SLIDE_M, TIME_S = 3e-9, 1e-7, 1e-6, 1e-9
#: integrator at the default rtol against the closed form (measured 2.1e-14 at most)
EXACT = 1e-12


def _plan(case: int):  # type: ignore[no-untyped-def]
    plan = replace(paper_scene(case).resolve(), record_mode=RECORD_SUMMARY)
    assert plan.rtol == Options().rtol  # 1e-9 when the numbers above were measured
    return plan


def _check(a: Summary, b: Summary, hook: float, pocket: float, slide: float, time: float) -> None:
    assert a.outcome == b.outcome == "pins"
    assert a.n_events == b.n_events
    assert a.hook_m is not None and b.hook_m is not None
    assert abs(a.hook_m - b.hook_m) < hook, (a.hook_m, b.hook_m)
    assert a.y_end_m is not None and b.y_end_m is not None
    assert abs(a.y_end_m - b.y_end_m) < hook, (a.y_end_m, b.y_end_m)
    assert a.pocket_deg is not None and b.pocket_deg is not None
    assert abs(a.pocket_deg - b.pocket_deg) < pocket, (a.pocket_deg, b.pocket_deg)
    if a.slide_m is None:
        assert b.slide_m is None
    else:
        assert b.slide_m is not None
        assert abs(a.slide_m - b.slide_m) < slide, (a.slide_m, b.slide_m)
    assert abs(a.time_s - b.time_s) < time, (a.time_s, b.time_s)


def test_the_cases_split_into_closed_form_and_integrated() -> None:
    assert [c for c in range(1, 19) if use_closed_form(_plan(c))] == list(UNIFORM)


@pytest.mark.parametrize("case", INTEGRATED)
def test_default_tolerance_is_converged(case: int) -> None:
    plan = _plan(case)
    a = solve(plan).summary
    b = solve(replace(plan, rtol=plan.rtol / 100.0)).summary
    assert b.n_steps > 2 * a.n_steps  # the tighter run really integrates again
    _check(a, b, HOOK_M, POCKET_DEG, SLIDE_M, TIME_S)


@pytest.mark.parametrize("case", UNIFORM)
def test_integrator_at_the_default_tolerance_is_the_closed_form(case: int) -> None:
    plan = _plan(case)
    exact = solve(plan, "closed_form").summary
    assert solve(plan).summary == exact  # what the default path runs
    integrated = solve(plan, "integrator").summary
    assert integrated.n_steps > 20
    _check(exact, integrated, EXACT, EXACT, EXACT, EXACT)
