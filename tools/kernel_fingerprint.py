"""Fingerprint of the compiled kernels' results over a fixed, broad set of deliveries.

    PYTHONPATH=TREE python tools/kernel_fingerprint.py OUT.json [--quick]
    python tools/kernel_fingerprint.py --compare A.json B.json
    python tools/kernel_fingerprint.py --subset FULL.json tests/fixtures/kernel-fingerprint-*.json
    (--replace: drop the other platforms' recordings)

A developer script: a change to ``bowlrec/core`` that must not change default results is run
here before and after (the "before" tree checked out with ``git worktree add``, run with
``PYTHONPATH`` pointing at it), and the two JSON files are compared key by key.

Deliveries: the 18 Table III cases as written and best fit, 200 random deliveries
(:func:`bowlrec.testing.random_plans`: offset balls, tilted spin, two lanes), the bowler and
paper example scenes under ``examples/``, and the default scene. Each runs through the
single-run kernel (:func:`bowlrec.core.solver.solve`) in every record mode (summary through
"auto", which takes the closed form where it applies, and through the integrator; steps; rate;
the paper's slide -> roll threshold; per-term torques for the Table III cases; observed stations
and turns), and all summary-only plans through the many-delivery kernel (serial and parallel).

Written per run: the summary (every metric, floats exactly as ``float.hex``) with its
right-hand-side, step and event counts, and for recorded runs a SHA-256 digest of every sample
array, event and observation. Batch outputs are digested whole.

Bits depend on the platform as well as on the code: numba compiles the kernels for the host
CPU (``llvmlite``'s host CPU name: instruction selection and vectorisation differ between,
say, a Haswell and an Emerald Rapids core), and NumPy's OpenBLAS picks its kernels by CPU too
(the 3 x 3 products and norms of ``resolve()`` and of the random deliveries). Measured between
two such machines: every solver count equal, metrics within 1e-9 relative, sample digests
different. A fingerprint therefore records :func:`platform`, and the test fixture keeps one
variant per platform it was recorded on (``--subset`` adds or replaces the variant of the full
fingerprint's platform); on a platform with no variant the test compares within a tolerance.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: example scenes fingerprinted (a fixed list: examples added later do not change the key set)
EXAMPLES = (
    "examples/bowler/house-shot-right.json",
    "examples/bowler/pocket-right.json",
    *(f"examples/paper/case{i:02d}.json" for i in range(1, 19)),
)
#: examples fingerprinted as the physical scene they resolved to when the fingerprint was
#: recorded: the kernel's fingerprint stays a fingerprint of the kernel when the bowlers' layer
#: (friction calibration, bowler types, lines) changes what the example resolves to
FROZEN_EXAMPLES = {
    "examples/bowler/house-shot-right.json": "tests/fixtures/house-shot-right-4045ef5.scene.json",
}


def _hex(x: Any) -> Any:
    if isinstance(x, float):
        return x.hex()
    return x


def _summary(traj: Any) -> dict[str, Any]:
    return {k: _hex(v) for k, v in dataclasses.asdict(traj.summary).items()}


def _digest(traj: Any) -> str:
    h = hashlib.sha256()
    for name in (
        "t_s",
        "position_m",
        "velocity_mps",
        "quaternion_wxyz",
        "omega_radps",
        "phase",
        "mu",
        "normal_force_N",
        "friction_force_N",
        "slip_mps",
        "energy_J",
        "alpha_radps2",
    ):
        a = np.ascontiguousarray(getattr(traj, name))
        h.update(name.encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    for name in sorted(traj.torques_Nm):
        h.update(name.encode())
        h.update(np.ascontiguousarray(traj.torques_Nm[name]).tobytes())
    for ev in traj.events:
        h.update(repr(dataclasses.astuple(ev)).encode())
    for ob in traj.observations:
        h.update(repr(dataclasses.astuple(ob)).encode())
    return h.hexdigest()


def deliveries(quick: bool = False) -> list[tuple[str, Any]]:
    """(name, summary-only Plan) of every delivery fingerprinted."""
    from bowlrec.paper import TABLE_III, paper_scene
    from bowlrec.scene_input import parse_scene_file
    from bowlrec.spec import Scene
    from bowlrec.testing import random_plans

    def summary_only(scene: Any) -> Any:
        options = scene.options.model_copy(update={"record": "summary"})
        return scene.model_copy(update={"options": options}).resolve()

    out: list[tuple[str, Any]] = []
    for variant in ("as_written", "best_fit"):
        for c in TABLE_III:
            out.append((f"case{c.case:02d}-{variant}", summary_only(paper_scene(c.case, variant))))
    out.extend(random_plans(20 if quick else 200))
    for rel in EXAMPLES:
        path = ROOT / FROZEN_EXAMPLES.get(rel, rel)
        out.append((rel, summary_only(parse_scene_file(path).scene)))
    out.append(("default", summary_only(Scene())))
    return out


def fingerprint(quick: bool = False) -> dict[str, Any]:
    from bowlrec.core.batch import pack_plans, run_batch
    from bowlrec.core.codes import (
        RECORD_RATE,
        RECORD_STEPS,
        SLIDE_TO_ROLL_THRESHOLD,
    )
    from bowlrec.core.solver import solve

    plans = deliveries(quick)
    summaries: dict[str, Any] = {}
    digests: dict[str, str] = {}
    for name, plan in plans:
        summaries[f"{name}|summary-auto"] = _summary(solve(plan))
        summaries[f"{name}|summary-integrator"] = _summary(solve(plan, method="integrator"))
        thr = dataclasses.replace(plan, slide_to_roll=SLIDE_TO_ROLL_THRESHOLD)
        summaries[f"{name}|summary-threshold"] = _summary(solve(thr))
        coarse = dataclasses.replace(plan, rtol=2e-4)
        summaries[f"{name}|summary-rtol2e-4"] = _summary(solve(coarse))
        steps = dataclasses.replace(plan, record_mode=RECORD_STEPS)
        t = solve(steps)
        summaries[f"{name}|steps"] = _summary(t)
        digests[f"{name}|steps"] = _digest(t)
        rate = dataclasses.replace(plan, record_mode=RECORD_RATE, record_dt_s=2e-3)
        t = solve(rate)
        summaries[f"{name}|rate"] = _summary(t)
        digests[f"{name}|rate"] = _digest(t)
        if name.startswith("case"):
            terms = dataclasses.replace(plan, record_mode=RECORD_STEPS, record_terms=True)
            t = solve(terms)
            summaries[f"{name}|terms"] = _summary(t)
            digests[f"{name}|terms"] = _digest(t)
            t = solve(plan, stations_m=(1.0, 5.0, 12.0, 18.0), turns=True)
            summaries[f"{name}|observed"] = _summary(t)
            digests[f"{name}|observed"] = _digest(t)
    batches: dict[str, str] = {}
    all_plans = [p for _, p in plans]
    for label, group in (
        ("all", all_plans),
        ("rtol2e-4", [dataclasses.replace(p, rtol=2e-4) for p in all_plans]),
    ):
        packed = pack_plans(group)
        for parallel in (False, True):
            res = run_batch(packed, parallel=parallel)
            h = hashlib.sha256()
            h.update(np.ascontiguousarray(res.out).tobytes())
            h.update(np.ascontiguousarray(res.events).tobytes())
            batches[f"{label}|{'parallel' if parallel else 'serial'}"] = h.hexdigest()
    return {"summaries": summaries, "digests": digests, "batches": batches}


def platform() -> dict[str, str]:
    """What the fingerprint's bits depend on besides the code: the CPU the kernels are compiled
    for, the OpenBLAS kernels NumPy uses, and the versions of the compiler stack."""
    import llvmlite
    import llvmlite.binding
    import numba
    from threadpoolctl import threadpool_info

    # NumPy's own BLAS (SciPy, once imported, loads a second copy that NumPy does not use)
    numpy_dir = str(Path(np.__file__).resolve().parent.parent)
    blas = sorted(
        {
            f"{info.get('internal_api')} {info.get('architecture')}"
            for info in threadpool_info()
            if info.get("user_api") == "blas"
            and str(Path(info.get("filepath", "")).resolve()).startswith(numpy_dir + "/numpy")
        }
    )
    return {
        "host_cpu": llvmlite.binding.get_host_cpu_name(),
        "blas": ", ".join(blas) or "none",
        "numpy": np.__version__,
        "numba": numba.__version__,
        "llvmlite": llvmlite.__version__,
    }


def compare(a_path: str, b_path: str) -> int:
    a = json.loads(Path(a_path).read_text())
    b = json.loads(Path(b_path).read_text())
    bad = 0
    if a.get("platform") != b.get("platform"):
        print(f"platforms differ: {a.get('platform')} vs {b.get('platform')}")
    for section in ("summaries", "digests", "batches"):
        ka, kb = set(a[section]), set(b[section])
        if ka != kb:
            print(f"{section}: key sets differ ({len(ka ^ kb)} keys)")
            bad += 1
        diff = [k for k in sorted(ka & kb) if a[section][k] != b[section][k]]
        n_rhs = sum(1 for k in ka & kb if section == "summaries" and "n_rhs" in a[section][k])
        extra = f" (with {n_rhs} right-hand-side counts)" if section == "summaries" else ""
        print(f"{section}: {len(ka & kb)} compared{extra}, {len(diff)} differ")
        for k in diff[:10]:
            print(f"  {k}")
        bad += len(diff)
    print("IDENTICAL" if bad == 0 else "DIFFERENT")
    return 0 if bad == 0 else 1


def random_run_id() -> str:
    """The run ID of the first random delivery (its plan goes through OpenBLAS)."""
    from bowlrec.archive import run_id
    from bowlrec.testing import random_plans

    return run_id(random_plans(1)[0][1])


def subset(full_path: str, fixture_path: str, source: str, *, replace: bool = False) -> int:
    """Add to the test fixture ``fixture_path`` (the subset of summaries and digests that
    ``tests/test_external_terms.py`` checks) the variant of the fingerprint ``full_path``'s
    platform: the fixture's keys with the full fingerprint's values. ``replace``: drop every
    other variant (after a deliberate change of the default physics)."""
    full = json.loads(Path(full_path).read_text())
    fixture = json.loads(Path(fixture_path).read_text())
    if "platform" not in full:
        raise SystemExit(f"{full_path}: no platform recorded; fingerprint it again")
    first = fixture["variants"][0]
    variant = {
        "platform": full["platform"],
        "random_run_id": full["random_run_id"],
        "summaries": {k: full["summaries"][k] for k in first["summaries"]},
        "digests": {k: full["digests"][k] for k in first["digests"]},
    }
    kept = [] if replace else [v for v in fixture["variants"] if v["platform"] != full["platform"]]
    new = {"source": source or fixture["source"], "variants": [*kept, variant]}
    Path(fixture_path).write_text(json.dumps(new, indent=0, sort_keys=True))
    print(
        f"{fixture_path}: {len(new['variants'])} platform variant(s), "
        f"{len(variant['summaries'])} summaries and {len(variant['digests'])} digests each"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", nargs="?", help="JSON file to write")
    ap.add_argument("--quick", action="store_true", help="20 random deliveries instead of 200")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two fingerprints")
    ap.add_argument(
        "--subset",
        nargs=2,
        metavar=("FULL", "FIXTURE"),
        help="rewrite a test fixture's keys from a full fingerprint",
    )
    ap.add_argument("--source", default="", help="with --subset: where FULL was computed")
    ap.add_argument(
        "--replace", action="store_true", help="with --subset: drop the other platforms' variants"
    )
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    if args.subset:
        return subset(*args.subset, args.source, replace=args.replace)
    if not args.out:
        ap.error("OUT.json is required")
    import bowlrec

    fp = fingerprint(args.quick)
    fp["bowlrec"] = str(Path(bowlrec.__file__).resolve().parent)
    fp["platform"] = platform()
    fp["random_run_id"] = random_run_id()
    Path(args.out).write_text(json.dumps(fp, indent=1, sort_keys=True) + "\n")
    print(
        f"{args.out}: {len(fp['summaries'])} summaries, {len(fp['digests'])} digests, "
        f"{len(fp['batches'])} batch outputs ({fp['bowlrec']})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
