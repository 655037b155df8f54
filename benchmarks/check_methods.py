"""Agreement of the benchmark methods on the 18 Table III cases (as written) at tight settings.

    python -m benchmarks.check_methods            # from the repository root
    python -m benchmarks.check_methods --extra    # also RK45 / LSODA and the impulse-snap scheme

Methods: bowlrec (rtol 1e-11, the reference), scipy DOP853 (rtol 1e-11, atol 1e-12) and the
paper's scheme (RK4, dt = 1 ms, 1 cm/s threshold, v snapped to R_con x w). Prints per case the
hook (m), pocket angle (deg) and slide (m) of every method, the differences to bowlrec, the
wall-clock time of one run (after a warm-up run that loads / compiles the kernels) and the
number of right-hand-side evaluations; then the worst differences and the timings per method.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from typing import Any

from bowlrec.core.plan import Plan
from bowlrec.testing.rk4 import paper_scheme
from bowlrec.testing.scenes import table3_plans

from .methods import bowlrec_solve, scipy_solve

Method = Callable[[Plan], dict[str, Any]]


def methods(extra: bool) -> dict[str, Method]:
    out: dict[str, Method] = {
        "bowlrec 1e-11": lambda p: bowlrec_solve(p, 1e-11),
        "DOP853 1e-11": lambda p: scipy_solve(p, "DOP853", 1e-11, 1e-12),
        "paper 1ms": lambda p: paper_scheme(p, 1e-3),
    }
    if extra:
        out["paper 1ms impulse"] = lambda p: paper_scheme(p, 1e-3, snap="impulse")
        out["RK45 1e-10"] = lambda p: scipy_solve(p, "RK45", 1e-10, 1e-11)
        out["LSODA 1e-10"] = lambda p: scipy_solve(p, "LSODA", 1e-10, 1e-11)
    return out


def timed(fn: Method, plan: Plan, repeat: int) -> tuple[dict[str, Any], float]:
    """Result and the best wall-clock time (s) of ``repeat`` runs."""
    best = math.inf
    out: dict[str, Any] = {}
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(plan)
        best = min(best, time.perf_counter() - t0)
    return out, best


def fmt(v: float | None, spec: str) -> str:
    if v is None:
        width = spec.split(".")[0]
        return format("-", f">{width}" if width else "")
    return format(v, spec)


def diff(a: float | None, b: float | None) -> float:
    if a is None and b is None:
        return 0.0
    if a is None or b is None:
        return math.nan
    return a - b


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--extra", action="store_true", help="also RK45, LSODA, impulse snap")
    ap.add_argument("--repeat", type=int, default=1, help="timing: best of N runs (default 1)")
    args = ap.parse_args(argv)

    plans = table3_plans()
    ms = methods(args.extra)
    ref = next(iter(ms))
    for fn in ms.values():  # warm-up: numba cache load / compilation, scipy imports
        fn(plans[4][1])

    results: dict[str, dict[str, dict[str, Any]]] = {name: {} for name in ms}
    for case, plan in plans:
        print(f"\n{case}")
        print(
            f"  {'method':<18} {'outcome':<8} {'hook (m)':>12} {'pocket (deg)':>13} "
            f"{'slide (m)':>12} {'d hook (m)':>11} {'d pocket':>10} {'d slide (m)':>11} "
            f"{'time (ms)':>10} {'n_rhs':>9}"
        )
        for name, fn in ms.items():
            r, wall = timed(fn, plan, args.repeat)
            r["wall_s"] = wall
            results[name][case] = r
            b = results[ref][case]
            dh = diff(r["hook_m"], b["hook_m"])
            dp = diff(r["pocket_deg"], b["pocket_deg"])
            ds = diff(r["slide_m"], b["slide_m"])
            print(
                f"  {name:<18} {r['outcome']:<8} {fmt(r['hook_m'], '12.8f')} "
                f"{fmt(r['pocket_deg'], '13.8f')} {fmt(r['slide_m'], '12.7f')} "
                f"{fmt(dh, '11.2e')} {fmt(dp, '10.2e')} {fmt(ds, '11.2e')} "
                f"{1e3 * wall:10.2f} {r['n_rhs']:9d}"
            )

    print("\nworst |difference| to", ref, "over the 18 cases, and time per case")
    print(
        f"  {'method':<18} {'hook (m)':>10} {'pocket (deg)':>13} {'slide (m)':>10} "
        f"{'median ms':>10} {'max ms':>9} {'total s':>8} {'outcomes':>9}"
    )
    for name in ms:
        rs = results[name]
        worst: dict[str, float] = {}
        for key in ("hook_m", "pocket_deg", "slide_m"):
            dk = [diff(rs[c][key], results[ref][c][key]) for c, _ in plans]
            vals = [abs(d) for d in dk]
            worst[key] = math.nan if any(math.isnan(v) for v in vals) else max(vals)
        walls = [rs[c]["wall_s"] for c, _ in plans]
        same = sum(rs[c]["outcome"] == results[ref][c]["outcome"] for c, _ in plans)
        print(
            f"  {name:<18} {worst['hook_m']:10.2e} {worst['pocket_deg']:13.2e} "
            f"{worst['slide_m']:10.2e} {1e3 * statistics.median(walls):10.2f} "
            f"{1e3 * max(walls):9.1f} {sum(walls):8.3f} {same:>6d}/18"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
