"""What the optional external terms cost the kernel and how far they move the ball.

    python -m benchmarks.lane_terms [--before REV_TREE] [--repeats 5] [--rounds 2]

Deliveries: the two bowler example scenes (``examples/bowler``; the house shot as the kernel
fingerprint keeps it, ``tests/fixtures/house-shot-right-4045ef5.scene.json``: 17 mph, 300 rpm
at the paper's friction levels), the 18 Table III cases as written and 20 of the benchmark's
random deliveries (:func:`bowlrec.testing.random_plans`), summary only, at their own tolerance
(rtol 1e-9), one thread.

Configurations: default (no external term), drag (C_D 0.47, rho 1.204 kg/m^3), drag + rolling
resistance (C_rr 0.005), a legal cross tilt (0.040 in across the 41.5 in lane), a height
profile (a 0.3 mm depression, a sine across the lane through 9 points: max slope 8.8e-4), Magnus
lift (Sawicki et al. 2003) and all of them at once (tilt and profile together would exceed the
slope limit: "all" has the tilt and no profile).

Measured per configuration: each delivery's kernel time (``kernel_call``: the compiled kernel
alone, median of ``--repeats``; for each delivery the configurations are timed in turn),
reported as the median over the deliveries and their sum, and the total right-hand sides; the
entry shift at the pins against the default (cm and boards, 1 board = 41.5 in / 39) for the
deliveries that reach the pins. The default scenes' kernel time
is also compared with an earlier tree (``--before``: a checkout, e.g. a ``git worktree``, run in
a subprocess with ``PYTHONPATH`` pointing at it, alternated with this tree ``--rounds`` times:
A B A B). The machine's load average is recorded before and after.

Writes ``benchmarks/results/lane_terms.json`` and ``lane_terms.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
BOARD_M = 41.5 * 0.0254 / 39.0
LEGAL_TILT = 0.040 / 41.5
W = 1.0668
PROFILE_Y = np.linspace(0.0, W, 9)
PROFILE_Z = -3e-4 * np.sin(math.pi * PROFILE_Y / W)  # a 0.3 mm depression

#: times the default deliveries' kernels in the tree on PYTHONPATH; prints a JSON result
SPEED = """
import importlib.util, json, statistics, sys, time
spec = importlib.util.spec_from_file_location("lane_terms_bench", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
spec.loader.exec_module(mod)
deliveries = mod.deliveries
import bowlrec
assert bowlrec.__file__.startswith(sys.argv[3]), bowlrec.__file__
from bowlrec.core.solver import kernel_call
import numba
numba.set_num_threads(1)
repeats = int(sys.argv[2])
times, rhs = [], 0
for name, plan in deliveries():
    fn, args = kernel_call(plan)
    r = fn(*args)
    rhs += int(r[8])
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        ts.append(time.perf_counter() - t0)
    times.append(statistics.median(ts))
print(json.dumps({"times": times, "rhs": rhs}))
"""


def deliveries() -> list[tuple[str, Any]]:
    """(name, summary-only Plan) of the benchmark's deliveries."""
    from bowlrec.paper import TABLE_III, paper_scene
    from bowlrec.scene_input import parse_scene_file
    from bowlrec.testing import random_plans
    from tools.kernel_fingerprint import FROZEN_EXAMPLES

    def summary(scene: Any) -> Any:
        return replace(scene.resolve(), record_mode=0)

    out = []
    for rel in ("examples/bowler/house-shot-right.json", "examples/bowler/pocket-right.json"):
        # the kernel fingerprint's scene for each example (tools/kernel_fingerprint.py): the
        # physical delivery these measurements were made on
        path = ROOT / FROZEN_EXAMPLES.get(rel, rel)
        out.append((Path(rel).stem, summary(parse_scene_file(path).scene)))
    for c in TABLE_III:
        out.append((f"case{c.case:02d}", summary(paper_scene(c.case))))
    out.extend(random_plans(20))
    return out


def configs() -> dict[str, dict[str, Any]]:
    from bowlrec.core.codes import LIFT_SAWICKI

    drag = {"drag_coefficient": 0.47}
    rr = {"rolling_resistance": 0.005}
    tilt = {"cross_slope": LEGAL_TILT}
    prof = {"profile_y_m": PROFILE_Y, "profile_z_m": PROFILE_Z}
    lift = {"lift_model": LIFT_SAWICKI}
    return {
        "default": {},
        "drag": drag,
        "drag + rolling resistance": {**drag, **rr},
        "legal cross tilt": tilt,
        "0.3 mm depression profile": prof,
        "Magnus": lift,
        "all (drag, rr, tilt, Magnus)": {**drag, **rr, **tilt, **lift},
    }


def _kernel_time(plan: Any, repeats: int) -> tuple[float, int]:
    """Median kernel time (s) of ``repeats`` calls, and the right-hand sides of one."""
    from bowlrec.core.solver import kernel_call

    fn, args = kernel_call(plan)
    r = fn(*args)
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts), int(r[8])


def measure(repeats: int) -> dict[str, Any]:
    """Every delivery under every configuration; the configurations are timed in turn for each
    delivery (so that a drift of the machine's speed hits them alike)."""
    import numba

    from bowlrec.core.solver import solve

    numba.set_num_threads(1)
    base = deliveries()
    names = [n for n, _ in base]
    cfgs = configs()
    times: dict[str, list[float]] = {k: [] for k in cfgs}
    rhs = dict.fromkeys(cfgs, 0)
    summaries: dict[str, list[Any]] = {k: [] for k in cfgs}
    for _, p in base:
        for label, change in cfgs.items():
            plan = replace(p, **change)
            t, n = _kernel_time(plan, repeats)
            times[label].append(t)
            rhs[label] += n
            summaries[label].append(solve(plan).summary)
    out: dict[str, Any] = {}
    ref = summaries["default"]
    for label in cfgs:
        plans = [replace(p, **cfgs[label]) for _, p in base]
        row: dict[str, Any] = {
            "median_ms": 1e3 * statistics.median(times[label]),
            "total_ms": 1e3 * sum(times[label]),
            "rhs": rhs[label],
            "closed_form_runs": sum(
                1 for p in plans if not p.external_terms and p.scalar_inertia and not p.has_offset
            ),
        }
        shifts = {}
        speeds = {}
        for name, s0, s1 in zip(names, ref, summaries[label], strict=True):
            if s0.outcome == s1.outcome == "pins":
                shifts[name] = s1.y_end_m - s0.y_end_m
                speeds[name] = (s1.speed_end_mps - s0.speed_end_mps) / s0.speed_end_mps
        row["entry_shift_cm"] = {k: 100.0 * v for k, v in shifts.items()}
        row["speed_change_pct"] = {k: 100.0 * v for k, v in speeds.items()}
        hooking = [k for k in ("house-shot-right", "pocket-right") if k in shifts]
        row["entry_shift_boards_bowler_examples"] = {k: shifts[k] / BOARD_M for k in hooking}
        row["median_abs_shift_boards"] = (
            statistics.median(abs(v) / BOARD_M for v in shifts.values()) if shifts else None
        )
        out[label] = row
        print(
            f"{label:32s} median {row['median_ms']:.3f} ms, rhs {rhs[label]}, shift "
            f"{row['entry_shift_boards_bowler_examples']}",
            flush=True,
        )
    return {"deliveries": names, "configs": out}


def against(before: str, repeats: int, rounds: int) -> dict[str, Any]:
    """Default deliveries' kernel times, this tree and ``before``, alternated."""
    res: dict[str, list[Any]] = {"before": [], "after": []}
    for _ in range(rounds):
        for label, tree in (("before", before), ("after", str(ROOT))):
            env = {**os.environ, "PYTHONPATH": tree, "NUMBA_NUM_THREADS": "1"}
            p = subprocess.run(
                [sys.executable, "-c", SPEED, __file__, str(repeats), tree],
                env=env,
                capture_output=True,
                text=True,
                check=True,
                cwd="/tmp",
            )
            res[label].append(json.loads(p.stdout.strip().splitlines()[-1]))
    b = [min(r["times"][i] for r in res["before"]) for i in range(len(res["before"][0]["times"]))]
    a = [min(r["times"][i] for r in res["after"]) for i in range(len(res["after"][0]["times"]))]
    ratios = [x / y for x, y in zip(a, b, strict=True)]
    return {
        "before_tree": before,
        "rounds": rounds,
        "before_median_ms": 1e3 * statistics.median(b),
        "after_median_ms": 1e3 * statistics.median(a),
        "median_ratio_after_over_before": statistics.median(ratios),
        "total_ratio": sum(a) / sum(b),
        "rhs_before": res["before"][0]["rhs"],
        "rhs_after": res["after"][0]["rhs"],
    }


def write(doc: dict[str, Any]) -> None:
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "lane_terms.json").write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    cfg = doc["configs"]
    lines = [
        "# Lane and air terms: kernel cost and entry shift",
        "",
        "Written by `python -m benchmarks.lane_terms` (see its docstring); equations and "
        "assumptions in docs/lane-and-air.md.",
        "",
        f"{len(doc['deliveries'])} deliveries (2 bowler examples, 18 Table III cases, 20 random "
        "offset balls), summary only, rtol 1e-9, one thread; kernel time = the compiled kernel "
        f"alone, median of {doc['repeats']} repeats per delivery. Load average before "
        f"{doc['load_before'][0]:.2f}, after {doc['load_after'][0]:.2f} on {doc['nproc']} cores "
        f"({doc['platform']}).",
        "",
        "| configuration | median per delivery (ms) | sum (ms) | right-hand sides | "
        "house-shot-right entry shift | pocket-right entry shift | median abs shift (boards) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for label, row in cfg.items():
        sh = row["entry_shift_boards_bowler_examples"]
        cm = row["entry_shift_cm"]

        def cell(k: str, sh: dict[str, float] = sh, cm: dict[str, float] = cm) -> str:
            return f"{cm[k]:+.2f} cm ({sh[k]:+.2f} boards)" if k in sh else "-"

        med = row["median_abs_shift_boards"]
        lines.append(
            f"| {label} | {row['median_ms']:.3f} | {row['total_ms']:.1f} | {row['rhs']} | "
            f"{cell('house-shot-right')} | {cell('pocket-right')} | "
            f"{'-' if med is None else f'{med:.2f}'} |"
        )
    lines += [
        "",
        "Entry shift: y at the pins minus the default's (+: left), for deliveries that reach "
        "the pins in both. The default row's uniform-ball deliveries (Table III cases without "
        f"an offset: {cfg['default']['closed_form_runs']} of them) use the closed form; with "
        "any term on they are integrated, which is part of the terms' cost.",
        "",
        "Speed lost at the pins (median over the deliveries, %): "
        + ", ".join(
            f"{k} {statistics.median(v['speed_change_pct'].values()):+.2f}"
            for k, v in cfg.items()
            if k != "default" and v["speed_change_pct"]
        )
        + ".",
    ]
    sp = doc.get("against_before")
    if sp:
        lines += [
            "",
            "## Default scenes against the tree without the terms",
            "",
            f"`{sp['before_tree']}` (before) and this tree (after), {sp['rounds']} alternated "
            "rounds, best per delivery: median kernel time "
            f"{sp['before_median_ms']:.4f} ms before, {sp['after_median_ms']:.4f} ms after; "
            f"median ratio after / before {sp['median_ratio_after_over_before']:.3f}, ratio of "
            f"the sums {sp['total_ratio']:.3f}; right-hand sides {sp['rhs_before']} before, "
            f"{sp['rhs_after']} after.",
        ]
    (RESULTS / "lane_terms.md").write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default=None, help="a checkout of the tree to compare with")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args(argv)
    load_before = os.getloadavg()
    doc: dict[str, Any] = {
        "repeats": args.repeats,
        "platform": platform.platform(),
        "nproc": os.cpu_count(),
        "python": sys.version.split()[0],
        "load_before": list(load_before),
    }
    doc.update(measure(args.repeats))
    if args.before:
        doc["against_before"] = against(args.before, args.repeats, args.rounds)
        print(json.dumps(doc["against_before"]))
    doc["load_after"] = list(os.getloadavg())
    write(doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
