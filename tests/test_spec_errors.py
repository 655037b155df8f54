"""format_validation_error renders one line per error, "loc: message"."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from pydantic import ValidationError

from bowlrec.spec import Scene, format_validation_error
from bowlrec.spec.errors import format_loc


def test_format_loc() -> None:
    assert format_loc(("ball", "rg_m", 1)) == "ball.rg_m[1]"
    assert format_loc(()) == "scene"
    assert format_loc(("lane", "friction", "zones", "zones", 0, "mu")) == (
        "lane.friction.zones.zones[0].mu"
    )


def test_one_line_per_error() -> None:
    with pytest.raises(ValidationError) as info:
        Scene.model_validate(
            {"ball": {"mass_kg": -1, "rg_m": [0.067, 0.2, 0.2]}, "options": {"junk": 1}}
        )
    lines = format_validation_error(info.value).splitlines()
    assert lines == [
        "ball.mass_kg: Input should be greater than 0 (got -1)",
        "ball.rg_m: rg_m[1] = 0.2 must be < radius_m = 0.1085 (a radius of gyration cannot "
        "exceed the radius for a body inside the sphere)",
        "options.junk: Extra inputs are not permitted (got 1)",
    ]


def test_a_boolean_is_not_a_number_in_scenes_and_jobs(tmp_path: Path) -> None:
    """Pydantic's lax mode would read ``true`` as 1 (m/s, runs, ...); every number field of a
    scene or a job refuses it, naming the field. Boolean fields still take booleans."""
    from bowlrec.batch.job_spec import load_job
    from bowlrec.errors import JobError, SceneInputError
    from bowlrec.scene_input import parse_scene_input

    for scene, words in (
        ({"delivery": {"speed_mps": True}}, "delivery.speed_mps: Input should be a number"),
        ({"delivery": {"omega_radps": [0, False, 0]}}, "delivery.omega_radps: Input should be"),
        ({"format": "bowler", "delivery": {"speed_mph": True}}, "delivery.speed_mph: Input"),
        ({"options": {"pins": {"seed": True}}}, "options.pins.seed: Input should be a number"),
    ):
        with pytest.raises(SceneInputError, match=re.escape(words)):
            parse_scene_input(scene)
    assert parse_scene_input({"options": {"pins": True}}).scene.options.pins is True
    job = {
        "format": "bowlrec-job",
        "name": "j",
        "base": {},
        "sweep": {"kind": "random", "n": True, "seed": 1, "axes": {"delivery.speed_mps": [7, 9]}},
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    with pytest.raises(JobError, match=re.escape("sweep.random.n: Input should be a number")):
        load_job(path)


def test_a_radius_of_gyration_under_a_thousandth_of_the_radius_is_refused() -> None:
    """rg 1e-6 m in a 0.1085 m ball stalled the integrator (an outcome other than the closed
    form's); radius / 1000 is the smallest radius of gyration accepted."""
    from bowlrec.errors import SceneInputError
    from bowlrec.scene_input import parse_scene_input

    with pytest.raises(SceneInputError, match=re.escape("rg_m[0] = 1e-06 must be at least")):
        parse_scene_input({"ball": {"rg_m": [1e-6, 1e-6, 1e-6]}})
    assert parse_scene_input({"ball": {"rg_m": [2e-4, 2e-4, 2e-4]}}).scene.ball.rg_m[0] == 2e-4
