"""An outcome in words: the core reports codes and numbers, the layer above tells them.

Every path that produces a run a user sees (``bowlrec.simulate``, ``run_plan``, the archive's
``simulate``, the batch engine's summary-only and recorded runs) gives the same message for the
same delivery; the core's ``solve`` leaves it empty.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import bowlrec
from bowlrec.archive import Archive
from bowlrec.batch import JobSpec, run_job
from bowlrec.core.batch import EVENT_CAP
from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.outcome import outcome_message
from bowlrec.core.solver import run_plan, solve
from bowlrec.spec import Scene

SUMMARY = {"record": "summary"}
#: one scene per outcome, with the message each must carry
CASES = {
    "pins": ({"options": SUMMARY}, "reached the pins"),
    "gutter": (
        {"delivery": {"takeoff_angle_deg": 5.0}, "options": SUMMARY},
        "the center crossed a lane edge at x = ",
    ),
    "stopped": (
        {"delivery": {"speed_mps": 2.0, "omega_radps": [0.0, -80.0, 0.0]}, "options": SUMMARY},
        "the ball stopped moving toward the pins at x = ",
    ),
    "airborne at release": (
        {
            "ball": {"com_offset_m": [0.0, 0.0, 0.002]},
            "delivery": {"omega_radps": [0.0, 80.0, 0.0]},
            "options": SUMMARY,
        },
        "the normal force is not positive at release",
    ),
    "airborne": (
        {
            "ball": {"com_offset_m": [0.002, 0.0, 0.0]},
            "delivery": {"omega_radps": [0.0, 80.0, 0.0]},
            "options": SUMMARY,
        },
        "the normal force reached zero at t = ",
    ),
    "pins, 40 friction zones crossed": (
        {
            "ball": {"com_offset_m": [0.0005, 0.0, 0.0]},
            "lane": {
                "friction": {
                    "kind": "grid",
                    "x_edges_m": [0.4 * (k + 1) for k in range(40)],
                    "mu": [[0.04 if k % 2 else 0.05] for k in range(41)],
                }
            },
            "options": SUMMARY,
        },
        "reached the pins",
    ),
    "max_time": (
        {"options": {**SUMMARY, "max_time_s": 0.5}},
        "no outcome within max_time_s = 0.5 s",
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_core_reports_numbers_and_run_plan_tells_them(name: str) -> None:
    scene, expected = CASES[name]
    plan = Scene.model_validate(scene).resolve()
    bare = solve(plan).summary
    told = run_plan(plan).summary
    assert bare.message == ""
    assert told.message.startswith(expected), told.message
    assert replace(told, message="") == bare  # the words are all run_plan adds
    assert told.message == outcome_message(
        told.outcome, told.time_s, told.x_end_m, plan.max_time_s, plan.max_steps
    )
    assert bowlrec.simulate(scene).summary == told


@pytest.mark.parametrize("record", ["summary", "steps"])
def test_batch_and_archive_runs_carry_the_same_words(tmp_path: Path, record: str) -> None:
    """The batch engine's summary-only path builds messages from its columns, its recorded path
    through run_plan; both land in the archive equal to bowlrec.simulate's."""
    scenes = [{**s, "options": {**s["options"], "record": record}} for s, _ in CASES.values()]
    job = JobSpec.model_validate(
        {"format": "bowlrec-job", "base": {}, "sweep": {"kind": "scenes", "scenes": scenes}}
    )
    archive = Archive(tmp_path / "archive")
    result = run_job(job, archive, workers=0)
    assert result.count("failed") == len([s for s in scenes if _fails(s)])
    checked = 0
    for row, scene in zip(result.rows, scenes, strict=True):
        if row["status"] == "failed":
            continue
        stored = archive.load(row["run_id"]).trajectory.summary
        assert stored.message == bowlrec.simulate(scene).summary.message
        checked += 1
    assert checked == len(scenes) - result.count("failed") >= 5
    # the zone case has more events than the many-delivery kernel keeps: re-run for them
    archived = [r["run_id"] for r in result.rows if r["status"] != "failed"]
    assert max(len(archive.load(rid).trajectory.events) for rid in archived) > EVENT_CAP


def _fails(scene: dict) -> bool:  # type: ignore[type-arg]
    """Outcomes the batch records as failures, not archived runs (see FAILED_OUTCOMES)."""
    plan = replace(Scene.model_validate(scene).resolve(), record_mode=RECORD_SUMMARY)
    return solve(plan).summary.outcome in {"airborne", "max_steps", "stalled"}
