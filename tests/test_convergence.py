"""Summary metrics at the default tolerance agree with a 100x tighter run on all 18 cases."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.solver import solve
from bowlrec.paper import paper_scene
from bowlrec.spec import Options


@pytest.mark.parametrize("case", list(range(1, 19)))
def test_default_tolerance_is_converged(case: int) -> None:
    plan = replace(paper_scene(case).resolve(), record_mode=RECORD_SUMMARY)
    default_rtol = Options().rtol
    assert plan.rtol == default_rtol
    a = solve(plan).summary
    b = solve(replace(plan, rtol=default_rtol / 100.0)).summary
    assert a.outcome == b.outcome
    assert a.hook_m is not None and b.hook_m is not None
    assert abs(a.hook_m - b.hook_m) < 1e-4  # 0.1 mm
    assert a.pocket_deg is not None and b.pocket_deg is not None
    assert abs(a.pocket_deg - b.pocket_deg) < 1e-3
    if a.slide_m is None:
        assert b.slide_m is None
    else:
        assert b.slide_m is not None
        assert abs(a.slide_m - b.slide_m) < 1e-4
    assert abs(a.time_s - b.time_s) < 1e-6
