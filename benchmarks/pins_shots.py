"""Strike percentage of whole shots and of bowler types, through the pins.

Each bowler type (the styles of ``bowlrec.bowling.styles``) throws on the house shot along the
line a bowler picks there (the rule of 31: aimed with ``bowlrec aim --rule-of-31``, as in
docs/calibration.md), then repeats it with the release scatter of a tour player and of a league
bowler (``bowlrec.bowling.variance.PRESETS``); every repeat runs down the lane and through the
pins (``bowlrec.bowling.shot_carry``). Reported per type and scatter: the share of repeats in the
pocket window, the strike share with its standard error, the carry of pocket hits and the most
frequent leaves.

    python -m benchmarks.pins_shots [--n 100]   # writes benchmarks/results/pins_shots.{md,json}
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
STYLES = ("stroker", "tweener", "cranker", "two-handed")
PATTERN = "house_shot_approx"
SCATTERS = ("pro", "league")


def main() -> None:
    from bowlrec.bowling.aim import aim
    from bowlrec.bowling.calibration import (
        Case,
        breakpoint_board_for,
        case_scene,
        pattern_length_ft,
    )
    from bowlrec.bowling.oil_friction import OilFrictionMapping
    from bowlrec.bowling.pocket import POCKET
    from bowlrec.bowling.shot_carry import shot_carry
    from bowlrec.bowling.variance import PRESETS

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, default=100, help="repeats per type and scatter")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    rows = []
    t0 = time.perf_counter()
    for style in STYLES:
        scene = case_scene(Case(style, PATTERN), OilFrictionMapping())  # the calibrated mapping
        length = pattern_length_ft(scene.pattern_model())
        found = aim(
            scene, ("laydown", "launch"), POCKET, breakpoint_board=breakpoint_board_for(length)
        )
        for scatter in SCATTERS:
            carry = shot_carry(found.scene, PRESETS[scatter], args.n, seed=31, workers=args.workers)
            doc = carry.to_dict()
            rows.append({"style": style, "scatter": scatter, "aimed": found.found, **doc})
            print(style, scatter, f"{100 * carry.strike_share:.0f} %", flush=True)
    RESULTS.mkdir(exist_ok=True)
    out = {"pattern": PATTERN, "n": args.n, "seconds": time.perf_counter() - t0, "rows": rows}
    (RESULTS / "pins_shots.json").write_text(json.dumps(out, indent=2) + "\n")
    lines = [
        "# Strike percentage by bowler type (house shot, rule-of-31 line)",
        "",
        f"{args.n} repeats per row through the pins, seed 31; the pins' tolerances drawn per "
        "repeat; the pin model's defaults. Pocket: the USBC window (boards 17-18, 4-6 deg). "
        f"{args.workers} worker processes on a shared 2-core machine, {out['seconds']:.0f} s "
        "in all.",
        "",
        "| type | scatter | in the pocket | strikes | carry of pocket hits "
        "| most frequent leaves |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        carry = "-" if r["carry"] is None else f"{100 * r['carry']:.0f} %"
        leaves = ", ".join(
            f"{name} {k}" for name, k in list(r["leaves"].items())[:4] if name != "strike"
        )
        lines.append(
            f"| {r['style']} | {r['scatter']} | {100 * r['pocket_share']:.0f} % | "
            f"{100 * r['strike_share']:.0f} % (± {100 * r['strike_share_se']:.0f}) | {carry} | "
            f"{leaves} |"
        )
    (RESULTS / "pins_shots.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
