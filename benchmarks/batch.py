"""Throughput of batch jobs (deliveries/s): summary only and with trajectories, 1 vs 2 local
worker processes, and a 2-worker dask.distributed LocalCluster.

    python -m benchmarks.batch [--n 120] [--out benchmarks/results]

Each configuration runs the same job (a Latin hypercube over speed, rev rate and axis rotation
of the bowler example scene) into a fresh archive through :func:`bowlrec.batch.run_prepared`,
the code path of ``bowlrec batch``: workers simulate, this process adds every run to the
archive. Also timed: the simulation alone (the same chunks on the same executors, nothing
written) to separate solver throughput from the archive cost, and one
end-to-end ``bowlrec batch`` command (process start-up included). The machine is shared: the
load average before and after is recorded. Writes ``batch.json`` and ``batch.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _job(n: int, record: str) -> Any:
    from bowlrec.batch import JobSpec

    return JobSpec.model_validate(
        {
            "name": f"bench-{record}",
            "base": "examples/bowler/house-shot-right.json",
            "sweep": {
                "kind": "lhs",
                "n": n,
                "seed": 11,
                "axes": {
                    "delivery.speed_mph": {"low": 14.0, "high": 20.0},
                    "delivery.rev_rate_rpm": {"low": 200.0, "high": 450.0},
                    "delivery.axis_rotation_deg": {"low": 20.0, "high": 70.0},
                },
            },
            "record": record,
        }
    )


def _simulate_only(prepared: list[Any], executor: Any, parallel: int) -> float:
    """Seconds to simulate every run on ``executor`` (chunks as the runner makes them)."""
    import math
    from concurrent.futures import wait

    from bowlrec.batch.runner import SimTask, simulate_chunk

    tasks = [SimTask(p.run_id, p.plan) for p in prepared]
    size = max(1, min(64, math.ceil(len(tasks) / (8 * parallel))))
    start = time.perf_counter()
    futs = [
        executor.submit(simulate_chunk, tasks[i : i + size]) for i in range(0, len(tasks), size)
    ]
    wait(futs)
    for f in futs:
        f.result()
    return time.perf_counter() - start


def measure(n: int) -> dict[str, Any]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from bowlrec.archive import Archive
    from bowlrec.batch import prepare_runs, run_prepared
    from bowlrec.batch.runner import _worker_init

    rows = []
    load_before = os.getloadavg()
    ctx = multiprocessing.get_context("forkserver")
    with tempfile.TemporaryDirectory() as tmp:
        for record in ("summary", "trajectory"):
            prepared = prepare_runs(_job(n, record), base_dir=ROOT)
            for label, workers in (("local, 1 worker", 1), ("local, 2 workers", 2)):
                with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init) as ex:
                    _simulate_only(prepared[: 2 * workers], ex, workers)  # start + warm workers
                    sim = _simulate_only(prepared, ex, workers)
                    archive = Archive(Path(tmp) / f"{record}-{workers}")
                    res = run_prepared(prepared, archive, executor=ex, workers=workers)
                rows.append(_row(record, label, n, res, sim))
            rows.append(_dask_row(record, n, prepared, Path(tmp) / f"{record}-dask"))
        cli = _cli(Path(tmp), n)
    return {
        "machine": {
            "platform": platform.platform(),
            "python": sys.version.split()[0],
            "cpu_count": os.cpu_count(),
            "loadavg_before": load_before,
            "loadavg_after": os.getloadavg(),
        },
        "n_runs": n,
        "rows": rows,
        "cli": cli,
    }


def _row(record: str, label: str, n: int, res: Any, sim_s: float) -> dict[str, Any]:
    assert res.counts["ok"] == n, res.counts
    return {
        "record": record,
        "executor": label,
        "runs": n,
        "elapsed_s": res.elapsed_s,
        "deliveries_per_s": n / res.elapsed_s,
        "archive_write_s_per_run": res.write_s / n,
        "solver_s_per_run": res.simulate_s / n,
        "simulate_only_per_s": n / sim_s,
    }


def _dask_row(record: str, n: int, prepared: list[Any], archive_dir: Path) -> dict[str, Any]:
    from distributed import Client, LocalCluster

    from bowlrec.archive import Archive
    from bowlrec.batch import run_prepared

    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
        Client(cluster) as client,
    ):
        ex = client.get_executor(pure=False)
        _simulate_only(prepared[:4], ex, 2)
        sim = _simulate_only(prepared, ex, 2)
        res = run_prepared(prepared, Archive(archive_dir), executor=ex, workers=2)
    return _row(record, "dask LocalCluster, 2 workers", n, res, sim)


def _cli(tmp: Path, n: int) -> dict[str, Any]:
    job = tmp / "job.json"
    spec = _job(n, "summary").model_dump(mode="json", by_alias=True)
    spec["base"] = str(ROOT / "examples" / "bowler" / "house-shot-right.json")
    job.write_text(json.dumps(spec))
    cmd = [sys.executable, "-m", "bowlrec.cli", "batch", str(job), "-a", str(tmp / "cli")]
    cmd += ["--out", str(tmp / "cli-table"), "--workers", "2", "--quiet"]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - start
    return {
        "command": "bowlrec batch JOB --workers 2 (summary)",
        "runs": n,
        "wall_s": wall,
        "deliveries_per_s": n / wall,
    }


def markdown(data: dict[str, Any]) -> str:
    m = data["machine"]
    lines = [
        "# Batch throughput",
        "",
        f"{data['n_runs']} bowler-scene deliveries per configuration (LHS over speed, rev rate, "
        f"axis rotation); {m['cpu_count']} cores, load average {m['loadavg_before'][0]:.2f} "
        f"before / {m['loadavg_after'][0]:.2f} after (shared machine); Python {m['python']}.",
        "",
        "| record | executor | batch deliveries/s | simulate only /s | archive write ms/run "
        "| solver ms/run |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in data["rows"]:
        lines.append(
            f"| {r['record']} | {r['executor']} | {r['deliveries_per_s']:.1f} | "
            f"{r['simulate_only_per_s']:.0f} | {1000 * r['archive_write_s_per_run']:.1f} | "
            f"{1000 * r['solver_s_per_run']:.2f} |"
        )
    c = data["cli"]
    lines += [
        "",
        f"End to end, `{c['command']}`: {c['runs']} runs in {c['wall_s']:.1f} s "
        f"({c['deliveries_per_s']:.1f} deliveries/s, process start-up included).",
        "",
        "batch deliveries/s: runs simulated and added to the archive per second of wall time. "
        "simulate only: the same runs on the same workers with nothing written. archive write: "
        "the parent's time per run to turn a result into a segment record and to seal and "
        "register segments (every 1,000 runs or every second). The workers simulate one run "
        "per Python call and the parent prepares and records every run in Python; at 120 runs "
        "a configuration, worker start-up is a large share of the wall time.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, default=120)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    os.chdir(ROOT)
    data = measure(args.n)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "batch.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / "batch.md").write_text(markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()
