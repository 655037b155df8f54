"""The first hour: how fast the command line answers and how smoothly a batch reports progress.

    python -m benchmarks.first_hour [--out benchmarks/results] [--repeats 3]

1. **Start-up** (fresh processes, median of 7): ``python -c "import bowlrec"``, ``bowlrec
   --version``, ``bowlrec --help`` and ``bowlrec runs list -h``, and which heavy modules
   each loads (none may: numba, h5py, pandas, pyarrow, matplotlib, rerun, mcap, scipy).
2. **Batch progress**: ``run_job`` on 2 worker processes, no archive, for the example jobs and
   two larger ones, with the chunk sizes :mod:`bowlrec.batch.spans` picks (``sized``) and with
   fixed chunks of the job's cap (``fixed``: every chunk ``min(cap, total / (4 x workers))``
   runs). For each: the seconds until the first progress report with a finished run (worker
   start-up: the compiled kernels load from numba's cache), the number of reports after it,
   the longest gap between two reports after it, and the wall time; the worker pool is
   started (by a run of the offset-random job) before the first measurement. Median of
   ``--repeats``.
   The two policies alternate which goes first; the wall-time ratio is the median of the
   pairs' ratios. Target: after the first finished run, no gap longer than 2 s on any job, at
   no cost in wall time on the 2,000-run bowler job and the 1,000,000-run summary job
   (ratio sized / fixed <= 1.05).

Writes ``first_hour.json`` and ``first_hour.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "h5py", "pandas", "pyarrow", "matplotlib", "rerun", "mcap", "scipy")
STARTUP = {
    "import bowlrec": [sys.executable, "-c", "import bowlrec"],
    "bowlrec --version": [sys.executable, "-m", "bowlrec.cli", "--version"],
    "bowlrec --help": [sys.executable, "-m", "bowlrec.cli", "--help"],
    "bowlrec runs list -h": [sys.executable, "-m", "bowlrec.cli", "runs", "list", "-h"],
}
#: target: the longest gap between progress reports after the first finished run, s
MAX_GAP_S = 2.0
#: target: wall time of sized chunks / fixed chunks on the large summary-only job
MAX_WALL_RATIO = 1.05


def _grid(name: str, n_speed: int, n_spin: int, record: str) -> dict[str, Any]:
    return {
        "format": "bowlrec-job",
        "name": name,
        "base": {"name": name, "options": {"record": record}},
        "sweep": {
            "kind": "grid",
            "axes": {
                "delivery.speed_mps": {"start": 6.0, "stop": 9.0, "num": n_speed},
                "delivery.omega_radps[1]": {"start": 10.0, "stop": 40.0, "num": n_spin},
            },
        },
        "record": "summary" if record == "summary" else "trajectory",
    }


def _bowler_lhs(n: int) -> dict[str, Any]:
    """The pipeline benchmark's bowler job (each run solves its launch angle) with ``n`` runs."""
    doc: dict[str, Any] = json.loads((ROOT / "benchmarks/jobs/bowler-lhs.json").read_text())
    doc["sweep"]["n"] = n
    doc["base"] = str(ROOT / "examples/bowler/house-shot-right.json")
    return doc


JOBS: dict[str, Path | dict[str, Any]] = {
    "bowler-lhs example (35 bowler scenes)": ROOT / "examples" / "jobs" / "bowler-lhs.json",
    "offset-random example (24 recorded)": ROOT / "examples" / "jobs" / "offset-random.yaml",
    "bowler LHS, 2,000 runs": _bowler_lhs(2000),
    "grid 2,000 recorded (steps)": _grid("grid-2000-steps", 40, 50, "steps"),
    "grid 1,000,000 summary-only": _grid("grid-1m", 1000, 1000, "summary"),
}
#: the jobs whose wall time is compared (the others are too short to time)
TIMED = ("bowler LHS, 2,000 runs", "grid 1,000,000 summary-only")


def startup(repeats: int = 7) -> list[dict[str, Any]]:
    rows = []
    for label, cmd in STARTUP.items():
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            subprocess.run(cmd, capture_output=True, check=True)
            times.append(time.perf_counter() - t0)
        rows.append({"command": label, "median_s": statistics.median(times), "heavy": _heavy(cmd)})
    return rows


def _heavy(cmd: list[str]) -> list[str]:
    """The heavy modules loaded by ``cmd`` (a ``python -c``/``-m`` command), found by running
    it again under a hook that prints sys.modules at exit."""
    code = (
        "import atexit, sys\n"
        f"atexit.register(lambda: print('MODULES', sorted(m for m in {HEAVY!r} "
        "if m in sys.modules), file=sys.stderr))\n"
    )
    if cmd[1] == "-c":
        run = [sys.executable, "-c", code + cmd[2]]
    else:
        run = [sys.executable, "-c", code + f"import runpy; sys.argv = {cmd[2:]!r}; "
               "runpy.run_module(sys.argv[0], run_name='__main__')"]  # fmt: skip
    out = subprocess.run(run, capture_output=True, text=True).stderr
    line = next((s for s in out.splitlines() if s.startswith("MODULES ")), "MODULES []")
    loaded: list[str] = json.loads(line.removeprefix("MODULES ").replace("'", '"'))
    return loaded


def _progress_once(job: Any, base_dir: Path, fixed: bool) -> dict[str, float]:
    from bowlrec.batch import run_job
    from bowlrec.batch.runner import _default_chunk

    total = job.count()
    chunk = _default_chunk(job, total, 2) if fixed else None
    seen: list[tuple[float, int]] = []
    t0 = time.perf_counter()

    def report(p: Any) -> None:
        seen.append((time.perf_counter() - t0, p.done))

    run_job(job, None, base_dir=base_dir, workers=2, chunk_size=chunk, progress=report,
            sink=lambda table: None)  # fmt: skip
    wall = time.perf_counter() - t0
    moving = [t for t, done in seen if done > 0]
    gaps = [b - a for a, b in zip(moving, moving[1:], strict=False)]
    return {
        "first_s": moving[0],
        "reports": float(len(moving)),
        "max_gap_s": max(gaps, default=0.0),
        "wall_s": wall,
    }


def progress(repeats: int) -> list[dict[str, Any]]:
    from bowlrec.batch import load_job
    from bowlrec.batch.job import JobSpec

    rows = []
    warm = ROOT / "examples" / "jobs" / "offset-random.yaml"
    _progress_once(load_job(warm), warm.parent, True)  # start the pool: not measured
    for label, source in JOBS.items():
        if isinstance(source, Path):
            job, base = load_job(source), source.parent
        else:
            job, base = JobSpec.model_validate(source), ROOT
        runs: dict[str, list[dict[str, float]]] = {"sized": [], "fixed": []}
        for r in range(repeats):  # alternating which goes first
            for policy in ("sized", "fixed") if r % 2 == 0 else ("fixed", "sized"):
                runs[policy].append(_progress_once(job, base, policy == "fixed"))
        ratio = statistics.median(
            s["wall_s"] / f["wall_s"] for s, f in zip(runs["sized"], runs["fixed"], strict=True)
        )
        for policy, measured in runs.items():
            med = {k: statistics.median(m[k] for m in measured) for k in measured[0]}
            row = {"job": label, "runs": job.count(), "chunks": policy, **med}
            rows.append(row | ({"wall_ratio": ratio} if policy == "sized" else {}))
    return rows


def _markdown(doc: dict[str, Any]) -> str:
    lines = [
        f"Measured {doc['date']} on {doc['machine']} (`python -m benchmarks.first_hour`).",
        "",
        "| start-up (fresh process, median of 7) | s | heavy modules loaded |",
        "|---|---|---|",
    ]
    for r in doc["startup"]:
        heavy = ", ".join(r["heavy"]) or "none"
        lines.append(f"| `{r['command']}` | {r['median_s']:.3f} | {heavy} |")
    lines += [
        "",
        f"Batch progress on 2 workers, no archive (median of {doc['repeats']}): `sized` chunks "
        "(bowlrec.batch.spans) against `fixed` chunks of the job's cap.",
        "",
        "| job | runs | chunks | first report (s) | reports | longest gap after it (s) "
        "| wall (s) | wall sized / fixed (median of pairs) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in doc["progress"]:
        ratio = f"{r['wall_ratio']:.3f}" if "wall_ratio" in r else ""
        lines.append(
            f"| {r['job']} | {r['runs']:,} | {r['chunks']} | {r['first_s']:.2f} | "
            f"{r['reports']:.0f} | {r['max_gap_s']:.2f} | {r['wall_s']:.2f} | {ratio} |"
        )
    t = doc["targets"]
    lines += [
        "",
        f"Targets: longest gap after the first report <= {MAX_GAP_S} s with sized chunks: "
        f"**{'met' if t['gap_met'] else 'missed'}** (worst {t['worst_gap_s']:.2f} s); wall time "
        f"sized / fixed <= {MAX_WALL_RATIO} on the timed jobs: "
        f"**{'met' if t['wall_met'] else 'missed'}** (worst {t['wall_ratio']:.3f}). The first "
        "report waits for the worker processes to start and load the compiled kernels; the "
        "progress bar says so while it waits.",
    ]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rows = progress(args.repeats)
    sized = [r for r in rows if r["chunks"] == "sized"]
    worst = max(r["max_gap_s"] for r in sized)
    ratio = max(r["wall_ratio"] for r in sized if r["job"] in TIMED)
    doc = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}",
        "repeats": args.repeats,
        "startup": startup(),
        "progress": rows,
        "targets": {
            "worst_gap_s": worst,
            "gap_met": worst <= MAX_GAP_S,
            "wall_ratio": ratio,
            "wall_met": ratio <= MAX_WALL_RATIO,
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "first_hour.json").write_text(json.dumps(doc, indent=2) + "\n")
    (args.out / "first_hour.md").write_text(_markdown(doc))
    sys.stdout.write(_markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
