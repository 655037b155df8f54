"""How far coverstock and surface grit move the breakpoint and the entry: the sensitivity table
of the ranked cover model (``docs/coverstock.md``).

    python benchmarks/coverstock_sensitivity.py

For the default ``BowlerScene()`` (its delivery, layout, lane and pattern), every coverstock at
the default ball's surface, at its assumed factors and at the low and high ends of its plausible
range (oil and dry factor one at a time, the other at its assumed value); then the default
ball's coverstock at grits 500 to polished, under the assumed surface model and under the low
and high ends of its plausible range (grit exponents and polished factors together, the end
that moves the friction least and the one that moves it most). Each row is one simulation
through ``BowlerScene.to_scene()``, reported by :func:`bowlrec.bowling.report.bowler_report`
(breakpoint board and ft, entry board and angle at 60 ft).

Writes ``benchmarks/results/coverstock_sensitivity.json`` (every number, the run IDs) and
``coverstock_sensitivity.md`` (the tables), and puts the tables into ``docs/coverstock.md``
between ``<!-- coverstock:begin -->`` and ``<!-- coverstock:end -->``. The output has no date or
timing: it changes only when the physics, the default scene or the model's numbers do.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import bowlrec
from bowlrec import PHYSICS_VERSION
from bowlrec.archive.run_id import run_id
from bowlrec.bowling.oil_friction import OilFrictionMapping, pattern_friction
from bowlrec.bowling.report import bowler_report
from bowlrec.bowling.scene import BowlerScene
from bowlrec.bowling.surface import (
    COVER_FACTORS,
    GRIT_EXPONENT_DRY,
    GRIT_EXPONENT_OIL,
    OIL_RANKING,
    POLISHED_DRY,
    POLISHED_OIL,
    REFERENCE_COVERSTOCK,
    REFERENCE_GRIT,
    Coverstock,
    Surface,
    surface_text,
)

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script: tools/ is importable from the repository root
    sys.path.insert(0, str(ROOT))
from tools.readme_blocks import replace_block  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
DOC = ROOT / "docs" / "coverstock.md"
BLOCK = "coverstock"
#: the surfaces of the grit sweep (Abralon steps and polish)
GRITS: tuple[Surface, ...] = (500, 1000, 1500, 2000, 3000, 4000, "polished")
#: what the tables report, with their column titles
METRICS = {
    "breakpoint_board": "breakpoint board",
    "breakpoint_ft": "breakpoint ft",
    "entry_board": "entry board",
    "entry_angle_deg": "entry angle (deg)",
}


@dataclass(frozen=True)
class Row:
    """One simulated variant: its labels, the friction levels it ran with, what it did."""

    labels: dict[str, Any]
    mu_oil: float
    mu_dry: float
    result: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {**self.labels, "mu_oil": self.mu_oil, "mu_dry": self.mu_dry, **self.result}


def _with(
    base: BowlerScene, coverstock: Coverstock, surface: Surface, mapping: OilFrictionMapping
) -> BowlerScene:
    ball = base.ball.model_copy(update={"coverstock": coverstock, "surface": surface})
    return BowlerScene.model_validate(
        {**base.model_dump(), "ball": ball.model_dump(), "oil_friction": mapping.model_dump()}
    )


def _check_wiring(scene: BowlerScene) -> None:
    """The physical scene's friction is the pattern's for this ball's coverstock and surface
    (else the table would not show what a user gets)."""
    physical = scene.to_scene().lane.friction
    expected = pattern_friction(
        scene.pattern_model(),
        lane_width_m=scene.lane.width_m,
        length_m=scene.lane.length_m,
        coverstock=scene.ball.coverstock,
        surface=scene.ball.surface,
        mapping=scene.oil_friction,
    )
    if getattr(physical, "mu", None) != expected.mu:
        sys.exit(
            "BowlerScene.to_scene() does not give the friction of the ball's coverstock and "
            "surface (pattern_friction(..., coverstock=..., surface=..., mapping=...)); "
            "the table would be wrong"
        )


def simulate(scene: BowlerScene, labels: dict[str, Any]) -> Row:
    """One run of ``scene``, reported in bowlers' terms."""
    physical = scene.to_scene()
    trajectory = bowlrec.simulate(physical)
    report = bowler_report(trajectory, scene.lane, scene.delivery.handedness)
    dry, oil = scene.oil_friction.levels(scene.ball.coverstock, scene.ball.surface)
    return Row(
        labels=labels,
        mu_oil=oil,
        mu_dry=dry,
        result={
            "outcome": report.outcome,
            "breakpoint_board": report.breakpoint_board,
            "breakpoint_ft": report.breakpoint_ft,
            "entry_board": report.entry_board,
            "entry_angle_deg": report.entry_angle_deg,
            "run_id": run_id(physical.resolve()),
        },
    )


def cover_rows(base: BowlerScene) -> list[Row]:
    """Every coverstock at the base ball's surface: assumed, then each factor at its ends."""
    surface = base.ball.surface
    rows = []
    for cover in OIL_RANKING:
        ranges = COVER_FACTORS[cover]
        cases: list[tuple[str, dict[str, Any]]] = [("assumed", {})]
        for level, which in (("oil", ranges.oil), ("dry", ranges.dry)):
            for end in ("low", "high"):
                value = getattr(which, end)
                if value != which.assumed:
                    cases.append((f"{level} {end}", {f"{level}_factor": {cover: value}}))
        for case, override in cases:
            mapping = OilFrictionMapping.model_validate(override)
            dry_f, oil_f = mapping.cover_factors(cover)
            labels = {"coverstock": cover, "case": case, "oil_factor": oil_f, "dry_factor": dry_f}
            rows.append(simulate(_with(base, cover, surface, mapping), labels))
    return rows


#: the surface model at the low end, assumed, and at the high end of its plausible range
SURFACE_SETTINGS: dict[str, dict[str, float]] = {
    "low": {
        "grit_exponent_oil": GRIT_EXPONENT_OIL.low,
        "grit_exponent_dry": GRIT_EXPONENT_DRY.low,
        "polished_oil_factor": POLISHED_OIL.high,
        "polished_dry_factor": POLISHED_DRY.high,
    },
    "assumed": {},
    "high": {
        "grit_exponent_oil": GRIT_EXPONENT_OIL.high,
        "grit_exponent_dry": GRIT_EXPONENT_DRY.high,
        "polished_oil_factor": POLISHED_OIL.low,
        "polished_dry_factor": POLISHED_DRY.low,
    },
}


def grit_rows(base: BowlerScene) -> list[Row]:
    """The base ball's coverstock at every surface of :data:`GRITS`, per surface setting."""
    cover = base.ball.coverstock
    rows = []
    for setting, params in SURFACE_SETTINGS.items():
        mapping = OilFrictionMapping.model_validate(params)
        for surface in GRITS:
            dry_f, oil_f = mapping.surface_factors(surface)
            labels = {
                "coverstock": cover,
                "surface": surface,
                "setting": setting,
                "oil_factor": oil_f,
                "dry_factor": dry_f,
            }
            rows.append(simulate(_with(base, cover, surface, mapping), labels))
    return rows


def _span(rows: list[Row], key: str) -> dict[str, float] | None:
    values = [r.result[key] for r in rows]
    if any(v is None for v in values):
        return None
    return {"min": min(values), "max": max(values), "move": max(values) - min(values)}


def _num(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def _mu(x: float) -> str:
    return f"{x:.4g}"


def _table(head: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return lines + ["| " + " | ".join(r) + " |" for r in rows]


def _metric_cells(row: Row) -> list[str]:
    return [_num(row.result[k]) for k in METRICS]


def _move_cell(span: dict[str, float] | None) -> str:
    if span is None:
        return "- (misses the pins)"
    return f"{span['min']:.2f} to {span['max']:.2f} ({span['move']:.2f})"


def _from_to_cell(a: float | None, b: float | None) -> str:
    if a is None or b is None:
        return "-"
    return f"{a:.2f} to {b:.2f} ({b - a:+.2f})"


def markdown(doc: dict[str, Any], covers: list[Row], grits: list[Row]) -> str:
    """The tables (no title: they go into docs/coverstock.md as they are)."""
    s = doc["scene"]
    out = [
        f"Default `BowlerScene()`: {s['handedness']}-hander, {s['speed_mph']:g} mph, "
        f"{s['rev_rate_rpm']:g} rpm, axis rotation {s['axis_rotation_deg']:g} deg, tilt "
        f"{s['axis_tilt_deg']:g} deg, pattern `{s['pattern']}` on a {s['lane_width_in']:g} in "
        f"lane; ball {s['coverstock']} at {surface_text(s['surface'])}. Reference ball "
        f"{REFERENCE_COVERSTOCK} at {REFERENCE_GRIT} grit: mu_oil {_mu(doc['mu_oil'])}, mu_dry "
        f"{_mu(doc['mu_dry'])} (the calibrated levels; also every ball under `cover_model: "
        f'"none"`: breakpoint board {_num(doc["no_cover_model"]["breakpoint_board"])} at '
        f"{_num(doc['no_cover_model']['breakpoint_ft'])} ft, entry board "
        f"{_num(doc['no_cover_model']['entry_board'])} at "
        f"{_num(doc['no_cover_model']['entry_angle_deg'])} deg). Boards are counted from the "
        "bowling hand's gutter; the breakpoint is the path's outermost point. bowlrec "
        f"{doc['bowlrec_version']}, physics {doc['physics_version']}; "
        "`python benchmarks/coverstock_sensitivity.py` writes this block.",
        "",
        f"**Coverstock** (surface {surface_text(s['surface'])}; factors multiply mu_oil and "
        "mu_dry; the ends vary one factor at a time):",
        "",
    ]
    out += _table(
        ["coverstock", "case", "oil factor", "dry factor", "mu oil", "mu dry", *METRICS.values()],
        [
            [
                r.labels["coverstock"],
                r.labels["case"],
                f"{r.labels['oil_factor']:g}",
                f"{r.labels['dry_factor']:g}",
                _mu(r.mu_oil),
                _mu(r.mu_dry),
                *_metric_cells(r),
            ]
            for r in covers
        ],
    )
    out += ["", "**Move across each coverstock's plausible range** (min to max (move)):", ""]
    move_rows = []
    for cover in OIL_RANKING:
        mine = [r for r in covers if r.labels["coverstock"] == cover]
        move_rows.append([cover, *(_move_cell(_span(mine, k)) for k in METRICS)])
    assumed = [r for r in covers if r.labels["case"] == "assumed"]
    move_rows.append(
        ["all six, assumed factors", *(_move_cell(_span(assumed, k)) for k in METRICS)]
    )
    out += _table(["coverstock", *METRICS.values()], move_rows)
    cover = s["coverstock"]
    out += ["", f"**Surface** ({cover}; assumed surface model):", ""]
    out += _table(
        ["surface", "oil factor", "dry factor", "mu oil", "mu dry", *METRICS.values()],
        [
            [
                surface_text(r.labels["surface"]),
                f"{r.labels['oil_factor']:.4g}",
                f"{r.labels['dry_factor']:.4g}",
                _mu(r.mu_oil),
                _mu(r.mu_dry),
                *_metric_cells(r),
            ]
            for r in grits
            if r.labels["setting"] == "assumed"
        ],
    )
    out += [
        "",
        f"**Move from 500 grit to polished** ({cover}), across the surface model's plausible "
        "range:",
        "",
    ]
    rows = []
    for setting, params in SURFACE_SETTINGS.items():
        m = OilFrictionMapping.model_validate(params)
        mine = [r for r in grits if r.labels["setting"] == setting]
        first, last = mine[0], mine[-1]
        rows.append(
            [
                setting,
                f"{m.grit_exponent_oil:g} / {m.grit_exponent_dry:g}",
                f"{m.polished_oil_factor:g} / {m.polished_dry_factor:g}",
                *(_from_to_cell(first.result[k], last.result[k]) for k in METRICS),
            ]
        )
    out += _table(
        ["surface model", "grit exponent oil / dry", "polished oil / dry", *METRICS.values()],
        rows,
    )
    return "\n".join(out) + "\n"


def main() -> None:
    base = BowlerScene()
    _check_wiring(_with(base, base.ball.coverstock, 500, OilFrictionMapping()))
    reference = OilFrictionMapping()
    none = simulate(
        _with(
            base, base.ball.coverstock, base.ball.surface, OilFrictionMapping(cover_model="none")
        ),
        {"cover_model": "none"},
    )
    covers = cover_rows(base)
    grits = grit_rows(base)
    d = base.delivery
    doc: dict[str, Any] = {
        "generated_by": "python benchmarks/coverstock_sensitivity.py",
        "bowlrec_version": bowlrec.__version__,
        "physics_version": PHYSICS_VERSION,
        "scene": {
            "handedness": d.handedness,
            "speed_mph": d.speed_mph,
            "rev_rate_rpm": d.rev_rate_rpm,
            "axis_rotation_deg": d.axis_rotation_deg,
            "axis_tilt_deg": d.axis_tilt_deg,
            "pattern": base.pattern if isinstance(base.pattern, str) else base.pattern.name,
            "lane_width_in": base.lane.width_in,
            "coverstock": base.ball.coverstock,
            "surface": base.ball.surface,
        },
        "reference": {"coverstock": REFERENCE_COVERSTOCK, "grit": REFERENCE_GRIT},
        "mu_oil": reference.mu_oil,
        "mu_dry": reference.mu_dry,
        "no_cover_model": none.to_dict(),
        "cover_factors": {
            c: {
                "oil": [f.oil.low, f.oil.assumed, f.oil.high],
                "dry": [f.dry.low, f.dry.assumed, f.dry.high],
            }
            for c, f in COVER_FACTORS.items()
        },
        "surface_settings": {
            k: OilFrictionMapping.model_validate(v).model_dump(
                include=set(SURFACE_SETTINGS["high"])
            )
            for k, v in SURFACE_SETTINGS.items()
        },
        "covers": [r.to_dict() for r in covers],
        "cover_moves": {
            c: {k: _span([r for r in covers if r.labels["coverstock"] == c], k) for k in METRICS}
            for c in OIL_RANKING
        },
        "grits": [r.to_dict() for r in grits],
    }
    run_ids = [r.result["run_id"] for r in covers if r.labels["case"] == "assumed"]
    doc["distinct_run_ids_of_the_six_covers"] = len(set(run_ids))
    assert np.isfinite([r.result["breakpoint_ft"] for r in covers + grits]).all()
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "coverstock_sensitivity.json").write_text(
        json.dumps(doc, indent=2, sort_keys=True) + "\n", encoding="utf-8"
    )
    text = markdown(doc, covers, grits)
    (RESULTS / "coverstock_sensitivity.md").write_text(text, encoding="utf-8")
    replace_block(DOC, BLOCK, text)
    print(text)


if __name__ == "__main__":
    main()
