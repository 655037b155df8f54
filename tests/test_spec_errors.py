"""format_validation_error renders one line per error, "loc: message"."""

from __future__ import annotations

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
