"""bowlrec's batch kernel against the speed-limit prototype, side by side at equal error.

    python -m benchmarks.speed_limit [--quick] [--prototype PATH] [--out benchmarks/results]

The prototype (``../shared/peers/speedlimit/fast.py`` beside the checkout, or ``--prototype``) is
a minimal compiled Dormand-Prince 5(4) integrator of the same model: summary only, no
friction-cone check while rolling. Both codes run the same deliveries:

* the 18 Table III cases as written, the work-precision benchmark's 200 random deliveries, and
  2,000 Table III cases perturbed at random (speed +-10 %, spin rate +-20 %, spin axis turned by
  up to 10 deg, take-off angle +-1 deg, release board +-10 cm; fixed seed);

at a ladder of tolerances. Each code's errors are taken against its own run at rtol 1e-10. For
each accuracy level (worst hook error <= 1 mm and <= 0.1 mm over all deliveries, and the same
for the 99th percentile of the hook error) the cheapest tolerance of each code that meets it is
chosen; the worst pocket and slide errors at that tolerance are reported beside it (the
prototype's slide is its first slide -> roll x, as bowlrec's).

The comparison is made twice: over all deliveries, and over those on which the two codes solve
the same equations (the friction cone never acts in bowlrec's reference run: no roll -> slide
event). On the others bowlrec integrates the stick-slip the cone check finds (roll -> slide ->
roll cycles, each a stiff restart of the slip) where the prototype keeps rolling.

Throughput: three fresh processes each time interleaved pairs of whole batch runs (bowlrec's
``run_batch``, the prototype's ``simulate_batch``) on 1 and on 2 numba threads, after a warm-up
run; the figure is the median over all pairs, the spread is the min..max. Ratios above 1 mean
bowlrec is faster. Writes ``speed_limit.json`` and ``speed_limit.md`` into the output directory.
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
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
from types import ModuleType
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PROTOTYPE = ROOT.parent / "shared" / "peers" / "speedlimit" / "fast.py"

#: tolerance ladders (each code picks the cheapest that meets a level)
BOWLREC_RTOLS = [5e-4, 3e-4, 2e-4, 1.5e-4, 1e-4, 7e-5, 5e-5, 3e-5, 2e-5, 1.5e-5, 1e-5, 7e-6, 5e-6]
PROTOTYPE_RTOLS = [
    1e-3, 7e-4, 5e-4, 3e-4, 2e-4, 1.5e-4, 1e-4, 7e-5, 5e-5, 3e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6,
    5e-7, 2e-7, 1e-7, 5e-8, 2e-8, 1e-8,
]  # fmt: skip
REFERENCE_RTOL = 1e-10
LEVELS_MM = (1.0, 0.1)
N_PERTURBED = 2000
SEED = 20261128
PROCESSES = 3
PAIRS_PER_PROCESS = 4


def load_prototype(path: Path) -> ModuleType:
    """Import the prototype's module from its file."""
    spec = importlib.util.spec_from_file_location("speedlimit_fast", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"prototype: cannot import {path}")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # numba's cache finds its functions' module by name
    spec.loader.exec_module(mod)
    return mod


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """v turned by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def deliveries(n_perturbed: int = N_PERTURBED) -> list[tuple[str, Any]]:
    """(name, Plan) of the compared deliveries: Table III, 200 random, ``n_perturbed`` perturbed
    Table III cases (summary only; deterministic)."""
    from bowlrec.testing.scenes import random_plans, table3_plans

    base = table3_plans()
    out = list(base) + list(random_plans(200))
    rng = np.random.default_rng(SEED)
    for k in range(n_perturbed):
        name, plan = base[k % len(base)]
        v = np.asarray(plan.velocity0_mps, dtype=float)
        speed = float(np.hypot(*v)) * rng.uniform(0.9, 1.1)
        toa = math.atan2(v[1], v[0]) + math.radians(rng.uniform(-1.0, 1.0))
        w = np.asarray(plan.omega0_radps, dtype=float) * rng.uniform(0.8, 1.2)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        w = _rotate(w, axis, math.radians(rng.uniform(0.0, 10.0)))
        pos = np.asarray(plan.position0_m, dtype=float).copy()
        pos[1] += rng.uniform(-0.1, 0.1)
        out.append(
            (
                f"{name}-p{k:04d}",
                replace(
                    plan,
                    velocity0_mps=np.array([speed * math.cos(toa), speed * math.sin(toa)]),
                    omega0_radps=w,
                    position0_m=pos,
                ),
            )
        )
    return out


def _rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> lane) of the unit quaternion (w, x, y, z)."""
    a, b, c, d = (float(x) for x in q)
    return np.array(
        [
            [1 - 2 * (c * c + d * d), 2 * (b * c - a * d), 2 * (b * d + a * c)],
            [2 * (b * c + a * d), 1 - 2 * (b * b + d * d), 2 * (c * d - a * b)],
            [2 * (b * d - a * c), 2 * (c * d + a * b), 1 - 2 * (b * b + c * c)],
        ]
    )


def prototype_scene(plan: Any) -> dict[str, Any]:
    """The prototype's scene dictionary for a bowlrec Plan (its body frame is the lane frame at
    release: J and r_delta are turned by the plan's initial orientation)."""
    rot = _rotation(plan.q0)
    inertia = rot @ np.diag(plan.inertia_per_mass_m2) @ rot.T
    v = np.asarray(plan.velocity0_mps, dtype=float)
    mu = np.asarray(plan.friction_mu, dtype=float)
    if mu.size == 1:
        friction: dict[str, Any] = {"type": "constant", "mu": float(mu.ravel()[0])}
    else:
        ye = np.asarray(plan.friction_y_edges_m, dtype=float)
        friction = {
            "type": "typical",
            "mu_oil": float(mu[0, 1]),
            "mu_dry": float(mu[1, 1]),
            "oil_length": float(plan.friction_x_edges_m[0]),
            "oil_width_frac": float((ye[1] - ye[0]) / plan.lane_width_m),
        }
    return {
        "R": plan.radius_m,
        "g": plan.g_mps2,
        "lane_length": plan.lane_length_m,
        "lane_width": plan.lane_width_m,
        "x0": float(plan.position0_m[0]),
        "y0": float(plan.position0_m[1]),
        "speed": float(np.hypot(*v)),
        "toa_deg": math.degrees(math.atan2(v[1], v[0])),
        "omega0": tuple(float(x) for x in plan.omega0_radps),
        "J": inertia,
        "r_delta": tuple(float(x) for x in rot @ np.asarray(plan.r_delta_body_m, dtype=float)),
        "friction": friction,
    }


def _check_supported(plans: list[tuple[str, Any]]) -> None:
    """The prototype knows a flat lane with constant or 'typical' friction and no external
    terms: refuse anything else rather than compare different models."""
    for name, p in plans:
        if p.external_terms or np.asarray(p.friction_mu).size not in (1, 6):
            raise SystemExit(f"{name}: not representable in the prototype")


SUBSETS = ("all", "same-equations")


def same_equations(plans: list[tuple[str, Any]]) -> np.ndarray:
    """Mask of the deliveries whose bowlrec reference run (rtol 1e-10) has no roll -> slide or
    slip-reversal event and at most the batch's event cap: the friction cone never acts, so the
    prototype (no cone check) integrates the same equations."""
    from bowlrec.core.batch import EVENT_CAP, pack_plans, run_batch
    from bowlrec.core.codes import EV_KIND, EVENT_ROLL_TO_SLIDE, EVENT_SLIP_REVERSAL

    res = run_batch(pack_plans([replace(p, rtol=REFERENCE_RTOL) for _, p in plans]))
    kinds = res.events[:, :, EV_KIND]
    n = res.n_events
    valid = np.arange(kinds.shape[1])[None, :] < n[:, None]
    cone = valid & ((kinds == EVENT_ROLL_TO_SLIDE) | (kinds == EVENT_SLIP_REVERSAL))
    return ~np.any(cone, axis=1) & (n <= EVENT_CAP)


def subset(plans: list[tuple[str, Any]], which: str) -> list[tuple[str, Any]]:
    """The deliveries of one comparison (``SUBSETS``)."""
    if which == "all":
        return plans
    mask = same_equations(plans)
    return [p for p, keep in zip(plans, mask, strict=True) if keep]


class Codes:
    """Both codes' batch entry points on the packed deliveries."""

    def __init__(self, proto: ModuleType, plans: list[tuple[str, Any]]) -> None:
        from bowlrec.core.batch import pack_plans

        self.proto = proto
        self.plans = [p for _, p in plans]
        self.names = [n for n, _ in plans]
        packed = [proto.pack_scene(prototype_scene(p)) for p in self.plans]
        self.y0s = np.array([y for y, _ in packed])
        self.ps = np.array([q for _, q in packed])
        self._pack = pack_plans
        self._packed: dict[float, Any] = {}

    def packed(self, rtol: float) -> Any:
        if rtol not in self._packed:
            self._packed[rtol] = self._pack([replace(p, rtol=rtol) for p in self.plans])
        return self._packed[rtol]

    def run_bowlrec(self, rtol: float, parallel: bool = True) -> Any:
        from bowlrec.core.batch import run_batch

        return run_batch(self.packed(rtol), parallel=parallel)

    def run_prototype(self, rtol: float, parallel: bool = True) -> np.ndarray:
        fn = self.proto.simulate_batch if parallel else self.proto.simulate_serial
        return fn(self.y0s, self.ps, rtol, rtol, max(1e-7, 30.0 * rtol))  # type: ignore[no-any-return]

    def metrics_bowlrec(self, rtol: float) -> dict[str, np.ndarray]:
        from bowlrec.core.batch import B_RHS, batch_metrics

        res = self.run_bowlrec(rtol)
        m = batch_metrics(self.packed(rtol), res)
        return {
            "status": np.array([str(o) for o in m["outcome"]]),
            "hook": m["hook_m"],
            "pocket": m["pocket_deg"],
            "slide": m["slide_m"],
            "n_rhs": res.out[:, B_RHS].copy(),
        }

    def metrics_prototype(self, rtol: float) -> dict[str, np.ndarray]:
        p = self.proto
        r = self.run_prototype(rtol)
        pins = r[:, p.S_STATUS] == p.ST_PINS
        return {
            "status": r[:, p.S_STATUS].astype(int).astype(str),
            "hook": np.where(pins, r[:, p.S_HOOK], np.nan),
            "pocket": np.where(pins, r[:, p.S_POCKET], np.nan),
            "slide": r[:, p.S_XROLL],
            "n_rhs": r[:, p.S_NFEV].copy(),
        }


def _worst(a: np.ndarray, b: np.ndarray, scale: float, q: float = 100.0) -> float:
    """Largest (or the q-th percentile of) |a - b| * scale over entries where both exist."""
    ok = ~(np.isnan(a) | np.isnan(b))
    return float(np.percentile(np.abs(a[ok] - b[ok]), q) * scale) if ok.any() else 0.0


def errors(res: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> dict[str, Any]:
    """Worst hook (mm), pocket (deg), slide (mm) errors and outcome mismatches."""
    return {
        "hook_mm": _worst(res["hook"], ref["hook"], 1e3),
        "hook_p99_mm": _worst(res["hook"], ref["hook"], 1e3, 99.0),
        "pocket_deg": _worst(res["pocket"], ref["pocket"], 1.0),
        "slide_mm": _worst(res["slide"], ref["slide"], 1e3),
        "outcome_mismatches": int(np.sum(res["status"] != ref["status"])),
        "n_rhs_median": float(np.median(res["n_rhs"])),
        "n_rhs_mean": float(np.mean(res["n_rhs"])),
    }


def ladder(codes: Codes, quick: bool) -> dict[str, list[dict[str, Any]]]:
    """Every tolerance's errors for both codes (against their own reference)."""
    out: dict[str, list[dict[str, Any]]] = {}
    for code, rtols, fn in (
        ("bowlrec", BOWLREC_RTOLS, codes.metrics_bowlrec),
        ("prototype", PROTOTYPE_RTOLS, codes.metrics_prototype),
    ):
        ref = fn(REFERENCE_RTOL)
        rows = []
        for rtol in rtols[::3] if quick else rtols:
            e = errors(fn(rtol), ref)
            e["rtol"] = rtol
            rows.append(e)
            print(
                f"{code} rtol {rtol:g}: hook {e['hook_mm']:.3g} mm, pocket {e['pocket_deg']:.2g}"
                f" deg, slide {e['slide_mm']:.3g} mm, {e['n_rhs_median']:.0f} RHS (median)",
                flush=True,
            )
        out[code] = rows
    return out


#: how a level is met: the worst hook error (the comparison asked for) or its 99th percentile
#: (one delivery that a code converges on slowly does not decide)
CRITERIA = {"worst": "hook_mm", "p99": "hook_p99_mm"}


def pick(
    rows: list[dict[str, Any]], level_mm: float, key: str = "hook_mm"
) -> dict[str, Any] | None:
    """The loosest tolerance whose hook error (``key``) meets the level (and every tighter one
    listed meets it too, so a lucky loose point is not taken)."""
    ok = [r[key] <= level_mm and r["outcome_mismatches"] == 0 for r in rows]
    for i, r in enumerate(rows):
        if all(ok[i:]):
            return r
    return None


def _worker(args: argparse.Namespace) -> None:
    """One timing process: interleaved pairs of whole batch runs, times printed as JSON."""
    import numba

    plans = subset(deliveries(args.n_perturbed), args.subset)
    codes = Codes(load_prototype(Path(args.prototype)), plans)
    numba.set_num_threads(args.threads)
    parallel = args.threads > 1
    times: dict[str, list[float]] = {"bowlrec": [], "prototype": []}
    codes.run_bowlrec(args.rtol_bowlrec, parallel)  # warm-up (and packing)
    codes.run_prototype(args.rtol_prototype, parallel)
    for k in range(args.pairs):
        order = ("bowlrec", "prototype") if k % 2 == 0 else ("prototype", "bowlrec")
        for code in order:
            t0 = time.perf_counter()
            if code == "bowlrec":
                codes.run_bowlrec(args.rtol_bowlrec, parallel)
            else:
                codes.run_prototype(args.rtol_prototype, parallel)
            times[code].append(time.perf_counter() - t0)
    print(json.dumps(times))


def throughput(
    prototype: Path,
    rtol_b: float,
    rtol_p: float,
    threads: int,
    n_perturbed: int,
    which: str,
    n: int,
    quick: bool,
) -> dict[str, Any]:
    """Medians (deliveries/s) over interleaved pairs in fresh processes."""
    times: dict[str, list[float]] = {"bowlrec": [], "prototype": []}
    for _ in range(1 if quick else PROCESSES):
        cmd = [
            sys.executable,
            "-m",
            "benchmarks.speed_limit",
            "--worker",
            "--prototype",
            str(prototype),
            "--rtol-bowlrec",
            repr(rtol_b),
            "--rtol-prototype",
            repr(rtol_p),
            "--threads",
            str(threads),
            "--pairs",
            str(2 if quick else PAIRS_PER_PROCESS),
            "--n-perturbed",
            str(n_perturbed),
            "--subset",
            which,
        ]
        done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=True)
        got = json.loads(done.stdout.strip().splitlines()[-1])
        for code in times:
            times[code].extend(got[code])
    b = [n / t for t in times["bowlrec"]]
    p = [n / t for t in times["prototype"]]
    ratios = [tp / tb for tb, tp in zip(times["bowlrec"], times["prototype"], strict=True)]
    return {
        "threads": threads,
        "bowlrec_per_s": {"median": statistics.median(b), "min": min(b), "max": max(b)},
        "prototype_per_s": {"median": statistics.median(p), "min": min(p), "max": max(p)},
        "ratio": {
            "median": statistics.median(ratios),
            "min": min(ratios),
            "max": max(ratios),
            "of_medians": statistics.median(b) / statistics.median(p),
        },
        "pairs": len(ratios),
    }


def _fmt(x: float) -> str:
    return f"{x:.2g}" if x < 10 else f"{x:.0f}"


def _side_by_side(comp: dict[str, Any]) -> list[str]:
    """The side-by-side table of one comparison."""
    lines = [
        "| hook error | threads | bowlrec rtol | bowlrec hook / pocket / slide | bowlrec "
        "deliveries/s (min..max) | prototype rtol | prototype hook / pocket / slide | prototype "
        "deliveries/s (min..max) | ratio (min..max) | target >= 1.0 |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for lv in comp["levels"]:
        b, p = lv["bowlrec"], lv["prototype"]
        for t in lv["throughput"]:
            bs, ps, r = t["bowlrec_per_s"], t["prototype_per_s"], t["ratio"]
            lines.append(
                f"| {lv['criterion']} <= {lv['level_mm']:g} mm | {t['threads']} | {b['rtol']:g} | "
                f"{b['hook_mm']:.2g} mm / {b['pocket_deg']:.2g} deg / {_fmt(b['slide_mm'])} mm | "
                f"{bs['median']:.0f} ({bs['min']:.0f}..{bs['max']:.0f}) | {p['rtol']:g} | "
                f"{p['hook_mm']:.2g} mm / {p['pocket_deg']:.2g} deg / {_fmt(p['slide_mm'])} mm | "
                f"{ps['median']:.0f} ({ps['min']:.0f}..{ps['max']:.0f}) | "
                f"{r['median']:.2f} ({r['min']:.2f}..{r['max']:.2f}) | "
                f"{'met' if r['median'] >= 1.0 else 'missed'} |"
            )
    lines += [
        "",
        "Right-hand sides per delivery at the chosen tolerances (mean; median): "
        + "; ".join(
            f"{lv['criterion']} <= {lv['level_mm']:g} mm: bowlrec "
            f"{lv['bowlrec']['n_rhs_mean']:.0f}; {lv['bowlrec']['n_rhs_median']:.0f}, prototype "
            f"{lv['prototype']['n_rhs_mean']:.0f}; {lv['prototype']['n_rhs_median']:.0f}"
            for lv in comp["levels"]
        )
        + ".",
    ]
    return lines


def page(result: dict[str, Any]) -> str:
    """The markdown results page."""
    titles = {
        "all": "All deliveries",
        "same-equations": "Deliveries on which the friction cone never acts (the same equations)",
    }
    lines = [
        "# bowlrec's kernel against the speed-limit prototype",
        "",
        "Written by `python -m benchmarks.speed_limit`. "
        f"{result['n_deliveries']} deliveries (18 Table III, 200 random, "
        f"{result['n_perturbed']} perturbed Table III); each code's errors against its own run "
        f"at rtol {REFERENCE_RTOL:g}; each level takes each code's loosest tolerance at which "
        "it and every tighter one meet the worst hook error. Throughput: median of "
        f"{result['pairs_note']}; ratio > 1: bowlrec faster. The prototype does not check the "
        "friction cone while rolling; bowlrec does: on deliveries where the cone acts the two "
        "integrate different equations, hence the second comparison.",
    ]
    for comp in result["comparisons"]:
        lines += ["", f"## {titles[comp['subset']]}: {comp['n_deliveries']}", ""]
        lines += _side_by_side(comp)
    lines += [
        "",
        "## The tolerance ladders",
        "",
        "| deliveries | code | rtol | worst hook (mm) | p99 hook (mm) | worst pocket (deg) | "
        "worst slide (mm) | outcome mismatches | RHS per delivery (mean; median) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for comp in result["comparisons"]:
        for code, rows in comp["ladder"].items():
            for r in rows:
                lines.append(
                    f"| {comp['subset']} | {code} | {r['rtol']:g} | {r['hook_mm']:.3g} | "
                    f"{r['hook_p99_mm']:.3g} | "
                    f"{r['pocket_deg']:.2g} | {r['slide_mm']:.3g} | {r['outcome_mismatches']} | "
                    f"{r['n_rhs_mean']:.0f}; {r['n_rhs_median']:.0f} |"
                )
    lines += ["", f"Machine: {result['machine']}.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--prototype", default=str(DEFAULT_PROTOTYPE))
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    ap.add_argument("--quick", action="store_true", help="fewer tolerances, one process")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--rtol-bowlrec", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--rtol-prototype", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--pairs", type=int, default=PAIRS_PER_PROCESS, help=argparse.SUPPRESS)
    ap.add_argument("--n-perturbed", type=int, default=N_PERTURBED, help=argparse.SUPPRESS)
    ap.add_argument("--subset", choices=SUBSETS, default="all", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        _worker(args)
        return 0
    prototype = Path(args.prototype)
    if not prototype.is_file():
        raise SystemExit(f"prototype not found: {prototype} (pass --prototype PATH)")
    n_perturbed = 200 if args.quick else N_PERTURBED
    everything = deliveries(n_perturbed)
    _check_supported(everything)
    proto = load_prototype(prototype)
    comparisons = []
    for which in SUBSETS:
        plans = subset(everything, which)
        print(f"{which}: {len(plans)} deliveries", flush=True)
        codes = Codes(proto, plans)
        lad = ladder(codes, args.quick)
        levels = []
        for (criterion, key), level in itertools.product(CRITERIA.items(), LEVELS_MM):
            b = pick(lad["bowlrec"], level, key)
            p = pick(lad["prototype"], level, key)
            if b is None or p is None:
                print(f"{criterion} hook <= {level:g} mm: no tolerance meets it", flush=True)
                continue
            tp = [
                throughput(
                    prototype, b["rtol"], p["rtol"], th, n_perturbed, which, len(plans), args.quick
                )
                for th in (1, 2)
            ]
            for t in tp:
                print(
                    f"{which}, {criterion} hook <= {level:g} mm, {t['threads']} thread(s): bowlrec "
                    f"{t['bowlrec_per_s']['median']:.0f}/s, prototype "
                    f"{t['prototype_per_s']['median']:.0f}/s, ratio {t['ratio']['median']:.2f}",
                    flush=True,
                )
            levels.append(
                {
                    "criterion": criterion,
                    "level_mm": level,
                    "bowlrec": b,
                    "prototype": p,
                    "throughput": tp,
                }
            )
        comparisons.append(
            {"subset": which, "n_deliveries": len(plans), "ladder": lad, "levels": levels}
        )
    pairs = (1 if args.quick else PROCESSES) * (2 if args.quick else PAIRS_PER_PROCESS)
    result = {
        "n_deliveries": len(everything),
        "n_perturbed": n_perturbed,
        "pairs_note": f"{pairs} interleaved pairs of batch runs in "
        f"{1 if args.quick else PROCESSES} fresh process(es)",
        "comparisons": comparisons,
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}",
        "quick": args.quick,
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "speed_limit.json").write_text(json.dumps(result, indent=1) + "\n")
    (out / "speed_limit.md").write_text(page(result))
    print(f"wrote {out / 'speed_limit.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
