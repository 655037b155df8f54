"""Pin action: run time against error over the engine's time step.

The same entries (a grid of boards x angles, each with a few pin-tolerance seeds) run at time
steps from 5e-5 s to 4e-4 s, the contact time constant held at its default (2 ms: the contacts
are the same springs and dampers, only resolved more or less finely; restitution is calibrated
at each step). Reported per step: the median wall time per delivery, and how often the leave
(the set of standing pins) and the touched pins differ from the finest step's. Pin action is
chaotic near thresholds, so the finest step is a reference, not the truth: the rate of
disagreement between two fine steps shows the floor.

    python -m benchmarks.pins_timestep      # writes benchmarks/results/pins_timestep.{md,json}
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
STEPS_S = (5e-5, 1e-4, 2e-4, 4e-4)
BOARDS = (15.5, 16.5, 17.5, 18.5, 19.5)
ANGLES_DEG = (2.0, 4.0, 6.0)
SEEDS = (None, 1, 2)


def _one(
    args: tuple[float, float, int | None, float],
) -> tuple[tuple[int, ...], tuple[int, ...], float]:
    from bowlrec.pins.deck import Deck, set_pins
    from bowlrec.pins.engine import simulate_pins
    from bowlrec.pins.entry import PinEntry, entry_state
    from bowlrec.spec.pins import PinOptions
    from bowlrec.spec.resolve import pin_plan

    board, angle, seed, step = args
    deck = Deck(18.288, 41.5 * 0.0254)
    pins = pin_plan(PinOptions(timestep_s=step))
    entry = entry_state(PinEntry(board=board, angle_deg=angle))
    t0 = time.perf_counter()
    action = simulate_pins(entry, pins, deck, set_pins(deck, seed=seed))
    return action.standing, action.touched, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    cases = [(b, a, s) for b in BOARDS for a in ANGLES_DEG for s in SEEDS]
    results: dict[float, list[tuple[tuple[int, ...], tuple[int, ...], float]]] = {}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for step in STEPS_S:
            # warm each worker's calibration for this step first (not timed)
            list(pool.map(_one, [(17.5, 6.0, None, step)] * args.workers))
            results[step] = list(pool.map(_one, [(*c, step) for c in cases]))
    ref = results[STEPS_S[0]]
    rows = []
    for step in STEPS_S:
        got = results[step]
        leave = sum(g[0] != r[0] for g, r in zip(got, ref, strict=True)) / len(cases)
        touched = sum(g[1] != r[1] for g, r in zip(got, ref, strict=True)) / len(cases)
        strikes = sum(g[0] == () for g in got) / len(cases)
        wall = statistics.median(g[2] for g in got)
        rows.append(
            {
                "timestep_s": step,
                "median_wall_s": wall,
                "leave_differs": leave,
                "touched_differs": touched,
                "strike_share": strikes,
            }
        )
    RESULTS.mkdir(exist_ok=True)
    doc = {"cases": len(cases), "boards": BOARDS, "angles_deg": ANGLES_DEG, "rows": rows}
    (RESULTS / "pins_timestep.json").write_text(json.dumps(doc, indent=2) + "\n")
    lines = [
        "# Pin action: time step against error",
        "",
        f"{len(cases)} entries (boards {BOARDS[0]}-{BOARDS[-1]}, angles "
        f"{', '.join(f'{a:g}' for a in ANGLES_DEG)} deg, nominal pins and 2 tolerance seeds), "
        f"the contact time constant 2 ms; differences against the {STEPS_S[0]:g} s step. "
        f"{args.workers} worker processes on a shared 2-core machine.",
        "",
        "| time step (s) | median wall per delivery (s) | leave differs | touched pins differ "
        "| strikes |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['timestep_s']:g} | {r['median_wall_s']:.3f} | {100 * r['leave_differs']:.0f} % "
            f"| {100 * r['touched_differs']:.0f} % | {100 * r['strike_share']:.0f} % |"
        )
    (RESULTS / "pins_timestep.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
