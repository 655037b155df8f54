"""Examples that seed the JSON editor of the Jobs page and the API's documentation: jobs
(``POST /jobs``) and scenes (``POST /runs``), each valid as it stands (tested)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal

__all__ = ["JOB_EXAMPLE", "SCENE_EXAMPLE", "SEEDS", "Seed"]

SCENE_EXAMPLE: dict[str, dict[str, Any]] = {
    "summary-only": {
        "summary": "A physical scene (defaults for everything not given)",
        "value": {
            "name": "quick",
            "delivery": {"speed_mps": 8.0},
            "options": {"record": "summary"},
        },
    },
    "bowler": {
        "summary": "A bowler-language scene",
        "value": {
            "format": "bowler",
            "delivery": {"speed_mph": 17, "rev_rate_rpm": 300},
            "options": {"record": "rate", "record_dt_s": 0.005},
        },
    },
}

JOB_EXAMPLE: dict[str, dict[str, Any]] = {
    "grid": {
        "summary": "A speed x side-rotation grid on a physical base scene",
        "value": {
            "format": "bowlrec-job",
            "name": "speed-side-spin",
            "description": (
                "omega_radps[0] turns the ball about the lane's x axis (side rotation): the "
                "more of it and the slower the ball, the more it hooks"
            ),
            "base": {"name": "grid"},
            "sweep": {
                "kind": "grid",
                "axes": {
                    "delivery.speed_mps": {"start": 7.0, "stop": 9.0, "num": 5},
                    "delivery.omega_radps[0]": [-3.0, -6.0, -9.0],
                },
            },
            "record": "summary",
        },
    },
    "bowler": {
        "summary": "A bowler's rev rate swept on the house shot",
        "value": {
            "format": "bowlrec-job",
            "name": "rev-rate",
            "base": {"format": "bowler", "delivery": {"speed_mph": 17}},
            "sweep": {
                "kind": "grid",
                "axes": {"delivery.rev_rate_rpm": {"start": 200.0, "stop": 450.0, "num": 11}},
            },
            "record": "summary",
        },
    },
    "scenes": {
        "summary": "Explicit scenes (shorthand)",
        "value": {"name": "two", "scenes": [{"delivery": {"speed_mps": 7.5}}, {"name": "b"}]},
    },
}


@dataclass(frozen=True)
class Seed:
    """One example of the editor: ``kind`` says where it is submitted (job: ``POST /jobs``,
    scene: ``POST /runs``)."""

    label: str
    kind: Literal["job", "scene"]
    value: dict[str, Any]

    def text(self) -> str:
        """The example as the editor shows it (indented JSON)."""
        return json.dumps(self.value, indent=2)


SEEDS: tuple[Seed, ...] = (
    *(Seed(f"Job: {e['summary']}", "job", e["value"]) for e in JOB_EXAMPLE.values()),
    *(Seed(f"Scene: {e['summary']}", "scene", e["value"]) for e in SCENE_EXAMPLE.values()),
)
