"""bowlrec's integrator with Dormand-Prince's 5(4) pair in place of Tsitouras', side by side.

    python -m benchmarks.rk_pair [--rounds 3] [--repeats 5]

Writes ``rk_pair.json`` and ``rk_pair.md`` into ``benchmarks/results``.

What is measured: the kernel is bowlrec's own, event handling, step control, slip layer and
error norm unchanged, with only the Runge-Kutta pair swapped. bowlrec integrates with Tsitouras'
5(4) pair (``bowlrec/core/tsit5.py``); the variant is a copy of the installed ``bowlrec`` package
in a scratch directory whose ``core/tsit5.py`` gets Dormand-Prince's tableau, embedded error
weights and 4th-order continuous extension (Hairer, Norsett and Wanner, "Solving Ordinary
Differential Equations I", Sec. II.5-II.6; the coefficients of their DOPRI5 code), the method
bowlrec used before. Both have 7 stages, the last at the new point (first same as last), so a
step costs 6 right-hand sides. Each variant runs in its own process (its own compiled kernels),
the two alternating ``--rounds`` times.

On the work-precision benchmark's 218 deliveries (``table3_plans()`` + ``random_plans(200)``),
summary only, one thread: errors against the work-precision reference (``_reference``: the
shipped pair at rtol 1e-12, slip layer 1e-8 m/s), right-hand sides, and the median kernel time
per delivery (``_time_bowlrec``: the median of ``--repeats`` calls of each delivery, in rounds
over every tolerance and delivery); the time in the table is the median over rounds. The
full-model targets are the work-precision benchmark's (``TARGETS``, ``TARGET_US``).
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
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RTOLS = [1e-4, 5e-5, 3e-5, 2e-5, 1.5e-5, 1e-5, 1e-6, 1e-8]
VARIANTS = ("Tsitouras 5(4)", "Dormand-Prince 5(4)")
#: the lines of ``core/tsit5.py`` that are the method (the rest reads only these names)
PAIR_START = "# --- the pair"
PAIR_END = "# --- end of the pair ---"

#: Dormand-Prince's pair under the names ``core/tsit5.py`` reads: stage rows, the solution's
#: weights (no stage 2: A72 = 0), error weights (E2 = 0) and Hairer's continuous extension
#: y + theta D + theta (1 - theta) (h f(y) - D + theta (2 D - h f(y) - h f(ynew) + (1 - theta)
#: h sum D_i K_i)) as the polynomial coefficients R_i2..R_i4 of b_i(theta)
DP5_CONSTANTS = """\
A21 = 0.2
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
)
A71, A72, A73, A74, A75, A76 = (
    35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
)
E1, E2, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
    -1.0 / 40.0,
)
_D = (
    -12715105075.0 / 11282082432.0, 0.0, 87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0,
)
_B = (A71, A72, A73, A74, A75, A76, 0.0)
_R4 = list(_D)
_R3 = [-2.0 * b - 2.0 * d + (1.0 if i in (0, 6) else 0.0) for i, (b, d) in enumerate(zip(_B, _D))]
_R2 = [b - r3 - r4 - (1.0 if i == 0 else 0.0) for i, (b, r3, r4) in enumerate(zip(_B, _R3, _R4))]
(R12, R22, R32, R42, R52, R62, R72) = _R2
(R13, R23, R33, R43, R53, R63, R73) = _R3
(R14, R24, R34, R44, R54, R64, R74) = _R4
"""


def dp5_module(tsit5: str) -> str:
    """The text of ``core/tsit5.py`` with Dormand-Prince's pair in place of Tsitouras'."""
    if tsit5.count(PAIR_START) != 1 or tsit5.count(PAIR_END) != 1:
        raise RuntimeError("core/tsit5.py changed: cannot find its pair's block once")
    start = tsit5.index("\n", tsit5.index(PAIR_START)) + 1
    return tsit5[:start] + DP5_CONSTANTS + tsit5[tsit5.index(PAIR_END) :]


def build_variant(dst: Path) -> Path:
    """A copy of the ``bowlrec`` package under ``dst`` with Dormand-Prince's pair; ``dst``."""
    import bowlrec

    package = Path(bowlrec.__file__).parent
    shutil.copytree(package, dst / "bowlrec", ignore=shutil.ignore_patterns("__pycache__"))
    method = dst / "bowlrec" / "core" / "tsit5.py"
    method.write_text(dp5_module(method.read_text()))
    return dst


def _child(refs_path: Path, repeats: int) -> None:
    """In a variant's process: the ladder over RTOLS, as JSON on stdout's last line."""
    from dataclasses import replace

    import bowlrec
    from bowlrec.core.codes import RECORD_SUMMARY
    from bowlrec.core.solver import solve
    from bowlrec.testing.scenes import random_plans, table3_plans

    from .work_precision import _aggregate, _errors, _metrics, _time_bowlrec

    refs = json.loads(refs_path.read_text())
    plans = table3_plans() + random_plans(200)
    wall = _time_bowlrec(plans, RTOLS, repeats)
    out = {"package": str(Path(bowlrec.__file__).parent), "ladder": []}
    for rtol in RTOLS:
        rows = []
        for (name, plan), ref in zip(plans, refs, strict=True):
            s = solve(replace(plan, rtol=rtol, record_mode=RECORD_SUMMARY)).summary
            rows.append(
                {"err": _errors(_metrics(s), ref), "wall_s": wall[(rtol, name)], "n_rhs": s.n_rhs}
            )
        out["ladder"].append({"rtol": rtol, "agg": _aggregate(rows)})
    print(json.dumps(out))


def _run(variant_root: Path, refs_path: Path, repeats: int) -> dict[str, Any]:
    """One variant's ladder in a fresh process whose ``bowlrec`` is the one at
    ``variant_root`` (the working directory comes first on its path)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "benchmarks.rk_pair", "--child", str(refs_path)]
    cmd += ["--repeats", str(repeats)]
    done = subprocess.run(cmd, cwd=variant_root, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{variant_root}: {done.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    if Path(result["package"]) != variant_root / "bowlrec":
        raise RuntimeError(f"the child ran {result['package']}, not {variant_root}")
    return result


def measure(rounds: int, repeats: int) -> dict[str, Any]:
    from bowlrec.testing.scenes import random_plans, table3_plans

    from .work_precision import TARGET_US, TARGETS, _meets, _reference

    plans = table3_plans() + random_plans(200)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        refs_path = tmp / "refs.json"
        refs_path.write_text(json.dumps([_reference(p) for _, p in plans]))
        roots = {VARIANTS[0]: ROOT, VARIANTS[1]: build_variant(tmp / "dp5")}
        runs: dict[str, list[dict[str, Any]]] = {v: [] for v in VARIANTS}
        for k in range(rounds):
            for variant in VARIANTS if k % 2 == 0 else VARIANTS[::-1]:
                runs[variant].append(_run(roots[variant], refs_path, repeats))
                print(f"round {k + 1}: {variant} done", flush=True)
    table: dict[str, list[dict[str, Any]]] = {}
    for variant, results in runs.items():
        rows = []
        for i, rtol in enumerate(RTOLS):
            aggs = [r["ladder"][i]["agg"] for r in results]
            times = [a["time_median_us"] for a in aggs]
            first = aggs[0]
            rows.append(
                {
                    "rtol": rtol,
                    "hook_mm": first["hook_mm"]["max"],
                    "pocket_deg": first["pocket_deg"]["max"],
                    "slide_mm": first["slide_mm"]["max"],
                    "outcome_mismatches": first["outcome_mismatches"],
                    "n_rhs_median": first["n_rhs_median"],
                    "time_median_us": statistics.median(times),
                    "time_rounds_us": times,
                    "meets_targets": _meets(first),
                }
            )
        table[variant] = rows
    cheapest = {
        v: min((r for r in rows if r["meets_targets"]), key=lambda r: r["time_median_us"])
        for v, rows in table.items()
    }
    return {
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count()},
        "deliveries": len(plans),
        "rounds": rounds,
        "repeats": repeats,
        "targets": TARGETS,
        "target_us": TARGET_US,
        "table": table,
        "cheapest": cheapest,
    }


def markdown(d: dict[str, Any]) -> str:
    lines = [
        "# bowlrec's integrator: Tsitouras' 5(4) pair against Dormand-Prince's",
        "",
        "`python -m benchmarks.rk_pair` (see its docstring): the kernel with only the "
        f"Runge-Kutta pair swapped, {d['deliveries']} deliveries (18 Table III + 200 random), "
        "summary only, one thread; errors against the work-precision reference; time per "
        f"delivery the median of {d['repeats']} kernel calls, the median over deliveries, then "
        f"over {d['rounds']} alternating rounds (min..max of the rounds beside it).",
        "",
        "| pair | rtol | max hook (mm) | max pocket (deg) | max slide (mm) | outcome mismatches "
        "| median RHS | median time / delivery (us) | meets hook, pocket, slide targets |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for variant, rows in d["table"].items():
        for r in rows:
            spread = f"{min(r['time_rounds_us']):.1f}..{max(r['time_rounds_us']):.1f}"
            lines.append(
                f"| {variant} | {r['rtol']:g} | {r['hook_mm']:.3g} | {r['pocket_deg']:.2g} | "
                f"{r['slide_mm']:.3g} | {r['outcome_mismatches']} | {r['n_rhs_median']:g} | "
                f"{r['time_median_us']:.1f} ({spread}) | {'yes' if r['meets_targets'] else 'no'} |"
            )
    t = d["targets"]
    ts, dp = (d["cheapest"][v] for v in VARIANTS)
    lines += [
        "",
        f"Cheapest tolerance meeting hook <= {t['hook_mm']} mm, pocket <= {t['pocket_deg']} deg "
        f"and slide <= {t['slide_mm']} mm on every delivery: {VARIANTS[0]} (bowlrec's method) "
        f"at rtol {ts['rtol']:g}, {ts['n_rhs_median']:g} right-hand sides and "
        f"{ts['time_median_us']:.1f} us (median); {VARIANTS[1]} at rtol {dp['rtol']:g}, "
        f"{dp['n_rhs_median']:g} right-hand sides and {dp['time_median_us']:.1f} us: "
        f"{dp['n_rhs_median'] / ts['n_rhs_median']:.2f}x fewer right-hand sides, "
        f"{dp['time_median_us'] / ts['time_median_us']:.2f}x the speed "
        f"(the work-precision target: {d['target_us']:.0f} us).",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    if args.child is not None:
        _child(args.child, args.repeats)
        return
    data = measure(args.rounds, args.repeats)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "rk_pair.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / "rk_pair.md").write_text(markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()
