"""The compiled core's build and run costs, this tree against an earlier commit.

    python -m benchmarks.core_layout [--before REV] [--after REV] [--rounds 3] [--out DIR]
                                     [--name core_layout]

Checks that a change to ``bowlrec/core`` costs nothing at run time or start-up.
``--before`` (and ``--after``, default: this working tree) are checked out into temporary git
worktrees; both trees run under this interpreter, each with ``PYTHONPATH`` pointing at its own
checkout, in alternation (A B A B ...): the machine's speed can drift with other load, and a
drift hits both alike. Per tree:

* **first compile**: the kernels' on-disk cache is deleted, then one fresh process compiles
  every kernel (:data:`WARM`: the integrator in all three recording modes and both slide ->
  roll rules, the closed form, the sample derivation and the many-delivery kernel serial and
  parallel); the whole process's wall time.
* **cold start**: the same process with the cache on disk (loading, not compiling).
* **speed**: in one process, the median over the benchmark's 218 deliveries (200 random offset
  balls and the 18 Table III cases, summary only, one thread) of each delivery's best-of-5
  kernel time, at rtol 2e-4 and 2e-6, plus the many-delivery kernel's throughput on all cores
  (best of 5 passes over the 218 x 10 deliveries); with the total right-hand sides, which must
  be identical (the same arithmetic).

Targets: first compile and cold start no worse than before (ratio after / before <= 1.05, the
machine's noise), kernel time no worse (median ratio <= 1.03). Writes ``NAME.json`` and
``NAME.md``. The committed results name their revisions (benchmarks/results/core_layout.md,
core_observe.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bowlrec.testing import random_scene_dicts

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_BEFORE = "3f7e090"  # the baseline of benchmarks/results/core_layout.md

#: compiles (or loads) every kernel once; prints nothing
WARM = """
import numpy as np
import bowlrec
from bowlrec.core.batch import pack_plans, run_batch
from bowlrec.core.solver import solve
from bowlrec.spec import Scene
ball = {"com_offset_m": [0.0, 0.0005, 0.0], "rg_m": [0.066, 0.067, 0.068]}
offset = {"ball": {**ball, "axis_2": [0.0, 1.0, 0.0]}}
plans = [
    Scene.model_validate({**offset, "options": {"record": rec}}).resolve()
    for rec in ("summary", "steps", "rate")
]
paper_rule = {"slide_to_roll": "threshold", "record": "summary"}
plans.append(Scene.model_validate({**offset, "options": paper_rule}).resolve())
plans.append(Scene.model_validate({"options": {"record": "summary"}}).resolve())
for p in plans:
    solve(p)
packed = pack_plans([plans[0], plans[-1]])
run_batch(packed, parallel=False)
run_batch(packed, parallel=True)
"""

#: times the kernels on the deliveries in the JSON file argv[1]; prints a JSON result
SPEED = """
import json, statistics, sys, time
from dataclasses import replace
from bowlrec.core.batch import pack_plans, run_batch
from bowlrec.core.solver import kernel_call
from bowlrec.paper import paper_scene
from bowlrec.scene_input import parse_scene
import numba
numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
dicts = json.load(open(sys.argv[1]))
base = [parse_scene(d).scene.resolve() for d in dicts]
base += [paper_scene(c, "as_written").resolve() for c in range(1, 19)]
out = {}
for rtol in (2e-4, 2e-6):
    plans = [replace(p, rtol=rtol, record_mode=0) for p in base]
    times, n_rhs = [], 0
    for p in plans:
        fn, args = kernel_call(p, "integrator")
        r = fn(*args)
        n_rhs += int(r[8])
        best = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            fn(*args)
            best = min(best, time.perf_counter() - t0)
        times.append(best)
    out[f"kernel_median_us_rtol_{rtol:g}"] = statistics.median(times) * 1e6
    out[f"kernel_total_ms_rtol_{rtol:g}"] = sum(times) * 1e3
    out[f"n_rhs_rtol_{rtol:g}"] = n_rhs
packed = pack_plans([replace(p, rtol=2e-4, record_mode=0) for p in base] * 10)
run_batch(packed, parallel=True)
best = float("inf")
for _ in range(5):
    t0 = time.perf_counter()
    run_batch(packed, parallel=True)
    best = min(best, time.perf_counter() - t0)
out["batch_per_s"] = packed.n / best
print(json.dumps(out))
"""


def _env(tree: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(tree)}


def _drop_cache(tree: Path) -> None:
    cache = tree / "bowlrec" / "core" / "__pycache__"
    for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
        f.unlink()


def _wall(tree: Path, code: str, *args: str) -> tuple[float, str]:
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code, *args],
        env=_env(tree),
        check=True,
        capture_output=True,
        text=True,
        cwd=tree,
    )
    return time.perf_counter() - t0, done.stdout


def _checkout(rev: str, where: Path, name: str) -> Path:
    tree = where / name
    subprocess.run(
        ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), rev],
        check=True,
        capture_output=True,
    )
    return tree


def measure(before: str, after: str | None, rounds: int) -> dict[str, Any]:
    """Alternate the two trees ``rounds`` times; returns every measurement and the medians."""
    tmp = Path(tempfile.mkdtemp(prefix="bowlrec-core-layout-"))
    try:
        trees = {
            "before": _checkout(before, tmp, "before"),
            "after": ROOT if after is None else _checkout(after, tmp, "after"),
        }
        scenes = tmp / "scenes.json"
        scenes.write_text(json.dumps(random_scene_dicts()))
        raw: dict[str, dict[str, list[Any]]] = {
            name: {"first_compile_s": [], "cold_start_s": [], "speed": []} for name in trees
        }
        for _ in range(rounds):
            for name, tree in trees.items():
                _drop_cache(tree)
                raw[name]["first_compile_s"].append(_wall(tree, WARM)[0])
            for name, tree in trees.items():
                raw[name]["cold_start_s"].append(_wall(tree, WARM)[0])
            for name, tree in trees.items():
                raw[name]["speed"].append(json.loads(_wall(tree, SPEED, str(scenes))[1]))
    finally:
        for name in ("before", "after"):
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tmp / name)],
                check=False,
                capture_output=True,
            )
        shutil.rmtree(tmp, ignore_errors=True)
    summary: dict[str, dict[str, float]] = {}
    for name, r in raw.items():
        s = {k: statistics.median(r[k]) for k in ("first_compile_s", "cold_start_s")}
        for key in r["speed"][0]:
            s[key] = statistics.median(run[key] for run in r["speed"])
        summary[name] = s
    ratios = {k: summary["after"][k] / summary["before"][k] for k in summary["after"]}
    return {
        "before": before,
        "after": after or "working tree",
        "rounds": rounds,
        "raw": raw,
        "median": summary,
        "ratio": ratios,
    }


TARGETS = {
    "first_compile_s": 1.05,
    "cold_start_s": 1.05,
    "kernel_median_us_rtol_0.0002": 1.03,
    "kernel_median_us_rtol_2e-06": 1.03,
}


def _markdown(res: dict[str, Any]) -> str:
    med, ratio = res["median"], res["ratio"]
    rows = [
        ("first compile, fresh process (s)", "first_compile_s", ".1f"),
        ("cold start, cache on disk (s)", "cold_start_s", ".2f"),
        ("kernel, median per delivery, rtol 2e-4 (us)", "kernel_median_us_rtol_0.0002", ".1f"),
        ("kernel, median per delivery, rtol 2e-6 (us)", "kernel_median_us_rtol_2e-06", ".1f"),
        ("many-delivery kernel, all cores (deliveries/s)", "batch_per_s", ",.0f"),
        ("right-hand sides, 218 deliveries, rtol 2e-4", "n_rhs_rtol_0.0002", ",.0f"),
        ("right-hand sides, 218 deliveries, rtol 2e-6", "n_rhs_rtol_2e-06", ",.0f"),
    ]
    lines = [
        "# The compiled core: build and run costs against an earlier layout",
        "",
        f"`python -m benchmarks.core_layout --before {res['before']} --after {res['after']}`: "
        f"medians of "
        f"{res['rounds']} alternating rounds on {os.cpu_count()} cores "
        f"({platform.processor() or platform.machine()}, Python {platform.python_version()}). "
        "A target is met when after / before stays within the machine's noise.",
        "",
        "| measure | before | after | after / before | target | met |",
        "|---|---|---|---|---|---|",
    ]
    for label, key, fmt in rows:
        target = TARGETS.get(key)
        if key.startswith("n_rhs"):
            target_text, met = "identical", "yes" if ratio[key] == 1.0 else "no"
        elif key == "batch_per_s":
            target_text, met = ">= 0.97", "yes" if ratio[key] >= 0.97 else "no"
        else:
            target_text = f"<= {target}"
            met = "yes" if target is not None and ratio[key] <= target else "no"
        lines.append(
            f"| {label} | {format(med['before'][key], fmt)} | {format(med['after'][key], fmt)} "
            f"| {ratio[key]:.3f} | {target_text} | {met} |"
        )
    lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=DEFAULT_BEFORE, help="git revision to compare with")
    parser.add_argument("--after", default=None, help="git revision (default: the working tree)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--name", default="core_layout", help="result files NAME.json and NAME.md")
    args = parser.parse_args()
    res = measure(args.before, args.after, args.rounds)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{args.name}.json").write_text(json.dumps(res, indent=1) + "\n")
    (args.out / f"{args.name}.md").write_text(_markdown(res))
    print(_markdown(res))


if __name__ == "__main__":
    main()
