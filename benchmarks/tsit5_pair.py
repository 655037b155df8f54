"""bowlrec's integrator with Tsitouras' 5(4) pair in place of Dormand-Prince's, side by side.

    python -m benchmarks.tsit5_pair [--rounds 3] [--repeats 5]

Writes ``tsit5_pair.json`` and ``tsit5_pair.md`` into ``benchmarks/results``.

What is measured (issue 32, item 1: "ideas worth measuring", before a method is adopted): the
kernel is bowlrec's own, event handling, step control, slip layer and error norm unchanged,
with only the Runge-Kutta pair swapped. The variant is a copy of the installed ``bowlrec``
package in a scratch directory whose ``core/dopri5.py`` gets Tsitouras' tableau, embedded error
weights and 4th-order continuous extension (Ch. Tsitouras, "Runge-Kutta pairs of order 5(4)
satisfying only the first column simplifying assumption", Comput. Math. Appl. 62, 770 (2011);
the double-precision coefficients as OrdinaryDiffEq.jl's ``Tsit5ConstantCache`` and
``Tsit5Interp`` give them). Like Dormand-Prince's it has 7 stages, the last at the new point
(first same as last), so a step costs 6 right-hand sides; unlike it, stage 2 enters the
solution (a72 = 0.01) and the error estimate. Each variant runs in its own process (its own
compiled kernels), the two alternating ``--rounds`` times.

On the work-precision benchmark's 218 deliveries (``table3_plans()`` + ``random_plans(200)``),
summary only, one thread: errors against the work-precision reference (``_reference``:
Dormand-Prince at rtol 1e-12, slip layer 1e-8 m/s), right-hand sides, and the median kernel
time per delivery (``_time_bowlrec``: the median of ``--repeats`` calls of each delivery, in
rounds over every tolerance and delivery); the time in the table is the median over rounds.
The full-model targets are the work-precision benchmark's (``TARGETS``, ``TARGET_US``).
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
VARIANTS = ("Dormand-Prince 5(4)", "Tsitouras 5(4)")

#: Tsitouras' pair (double precision): stage coefficients, error weights (b - b_hat) and the
#: continuous extension b_i(theta) = R_i1 theta + R_i2 theta^2 + R_i3 theta^3 + R_i4 theta^4
TSIT5_CONSTANTS = """\
A21 = 0.161
A31, A32 = -0.008480655492356989, 0.335480655492357
A41, A42, A43 = 2.8971530571054935, -6.359448489975075, 4.3622954328695815
A51, A52, A53, A54 = (
    5.325864828439257, -11.748883564062828, 7.4955393428898365, -0.09249506636175525
)
A61, A62, A63, A64, A65 = (
    5.86145544294642, -12.92096931784711, 8.159367898576159, -0.071584973281401,
    -0.028269050394068383,
)
A71, A72, A73, A74, A75, A76 = (
    0.09646076681806523, 0.01, 0.4798896504144996, 1.379008574103742, -3.290069515436081,
    2.324710524099774,
)
E1, E2, E3, E4, E5, E6, E7 = (
    -0.00178001105222577714, -0.0008164344596567469, 0.007880878010261995,
    -0.1447110071732629, 0.5823571654525552, -0.45808210592918697, 0.015151515151515152,
)
R11, R12, R13, R14 = 1.0, -2.763706197274826, 2.9132554618219126, -1.0530884977290216
R22, R23, R24 = 0.13169999999999998, -0.2234, 0.1017
R32, R33, R34 = 3.9302962368947516, -5.941033872131505, 2.490627285651253
R42, R43, R44 = -12.411077166933676, 30.33818863028232, -16.548102889244902
R52, R53, R54 = 37.50931341651104, -88.1789048947664, 47.37952196281928
R62, R63, R64 = -27.896526289197286, 65.09189467479366, -34.87065786149661
R72, R73, R74 = 1.5, -4.0, 2.5
"""

TSIT5_DENSE = '''\
@njit(cache=True, error_model="numpy", **NO_NRT)
def dense_coeffs(y, ynew, K, h, rc):  # type: ignore[no-untyped-def]
    """The continuous extension as a polynomial in theta: rc[0] + theta (rc[1] + ...)."""
    for i in range(N_STATE):
        rc[0, i] = y[i]
        rc[1, i] = h * (R11 * K[0, i])
        rc[2, i] = h * (
            R12 * K[0, i] + R22 * K[1, i] + R32 * K[2, i] + R42 * K[3, i] + R52 * K[4, i]
            + R62 * K[5, i] + R72 * K[6, i]
        )
        rc[3, i] = h * (
            R13 * K[0, i] + R23 * K[1, i] + R33 * K[2, i] + R43 * K[3, i] + R53 * K[4, i]
            + R63 * K[5, i] + R73 * K[6, i]
        )
        rc[4, i] = h * (
            R14 * K[0, i] + R24 * K[1, i] + R34 * K[2, i] + R44 * K[3, i] + R54 * K[4, i]
            + R64 * K[5, i] + R74 * K[6, i]
        )


@njit(cache=True, error_model="numpy", **NO_NRT)
def dense(rc, theta, out):  # type: ignore[no-untyped-def]
    for i in range(N_STATE):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + theta * (rc[2, i] + theta * (rc[3, i] + theta * rc[4, i]))
        )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def dense_planar(rc, theta, out):  # type: ignore[no-untyped-def]
    for i in (0, 1, 2, 3, 8, 9):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + theta * (rc[2, i] + theta * (rc[3, i] + theta * rc[4, i]))
        )
'''


def _swap(text: str, old: str, new: str) -> str:
    if text.count(old) != 1:
        raise RuntimeError(f"core/dopri5.py changed: cannot find {old[:60]!r} once")
    return text.replace(old, new)


def tsit5_module(dopri5: str) -> str:
    """The text of ``core/dopri5.py`` with Tsitouras' pair in place of Dormand-Prince's."""
    start = dopri5.index("C2, C3, C4, C5 = ")
    text = dopri5[:start] + TSIT5_CONSTANTS + dopri5[dopri5.index("N_STAGES = 7") :]
    text = _swap(
        text, "A71 * K[0, i] + A73 * K[2, i]", "A71 * K[0, i] + A72 * K[1, i] + A73 * K[2, i]"
    )
    text = _swap(text, "E1 * K[0, i] + E3 * K[2, i]", "E1 * K[0, i] + E2 * K[1, i] + E3 * K[2, i]")
    return (
        text[: text.index('@njit(cache=True, error_model="numpy", **NO_NRT)\ndef dense_coeffs')]
        + TSIT5_DENSE
    )


def build_variant(dst: Path) -> Path:
    """A copy of the ``bowlrec`` package under ``dst`` with the Tsitouras pair; ``dst``."""
    import bowlrec

    package = Path(bowlrec.__file__).parent
    shutil.copytree(package, dst / "bowlrec", ignore=shutil.ignore_patterns("__pycache__"))
    method = dst / "bowlrec" / "core" / "dopri5.py"
    method.write_text(tsit5_module(method.read_text()))
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
    cmd = [sys.executable, "-m", "benchmarks.tsit5_pair", "--child", str(refs_path)]
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
        roots = {VARIANTS[0]: ROOT, VARIANTS[1]: build_variant(tmp / "tsit5")}
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
        "# bowlrec's integrator with Tsitouras' 5(4) pair",
        "",
        "`python -m benchmarks.tsit5_pair` (see its docstring): the kernel with only the "
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
    dp, ts = (d["cheapest"][v] for v in VARIANTS)
    lines += [
        "",
        f"Cheapest tolerance meeting hook <= {t['hook_mm']} mm, pocket <= {t['pocket_deg']} deg "
        f"and slide <= {t['slide_mm']} mm on every delivery: {VARIANTS[0]} at rtol "
        f"{dp['rtol']:g}, {dp['n_rhs_median']:g} right-hand sides and {dp['time_median_us']:.1f} "
        f"us (median); {VARIANTS[1]} at rtol {ts['rtol']:g}, {ts['n_rhs_median']:g} right-hand "
        f"sides and {ts['time_median_us']:.1f} us: "
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
    (args.out / "tsit5_pair.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / "tsit5_pair.md").write_text(markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()
