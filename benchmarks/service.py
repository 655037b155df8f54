"""Latency and throughput of the HTTP service (``bowlrec serve``) on this machine.

    python -m benchmarks.service [--requests 200] [--clients 16] [--per-client 20]
                                 [--out benchmarks/results]

Starts a real server (uvicorn, 127.0.0.1, a fresh archive in a temporary directory, kernels
loaded from numba's on-disk cache) and measures with httpx:

- one client, one request at a time: ``POST /runs`` of a new summary-only scene (simulated,
  written to the archive: a segment fsynced and registered, shared by concurrent requests), of
  an already archived scene (content ID found, nothing written), ``GET /runs/{id}`` and
  ``GET /runs?limit=50``; p50/p95/mean in milliseconds over ``--requests`` requests each;
- concurrent clients: ``--clients`` threads x ``--per-client`` submissions, each followed by a
  ``GET`` of the run; once with every scene new and once with each scene submitted ~5 times (the
  concurrency test's mix): requests/s and new runs/s;
- a background job of ``--requests`` summary-only scenes (``POST /jobs``, polled): runs/s.

Writes ``service.json`` and ``service.md`` with the machine's load average before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
SERVE = "import sys; import bowlrec.cli.serve; from bowlrec.cli import app; app()"


def scene(i: int, name: str) -> dict[str, Any]:
    """A distinct summary-only scene per ``i`` (the closed-form solver). The name is not part
    of the content ID: each measurement uses its own range of ``i``."""
    return {
        "name": name,
        "delivery": {"speed_mps": round(6.0 + 1e-6 * i, 8)},
        "options": {"record": "summary"},
    }


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def server(archive: Path, *options: str) -> Iterator[str]:
    """A ``bowlrec serve`` subprocess (with extra CLI ``options``); yields its base URL."""
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if k != "BOWLREC_TOKEN"}
    cmd = [sys.executable, "-c", SERVE, "serve", "--archive", str(archive), "--port", str(port)]
    cmd += list(options)
    proc = subprocess.Popen(
        [*cmd, "--log-level", "warning"], env=env, cwd=ROOT, stdout=subprocess.DEVNULL
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError("the server did not start") from None
                time.sleep(0.05)
        yield url
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()


def _stats(ms: list[float]) -> dict[str, float]:
    q = statistics.quantiles(ms, n=100, method="inclusive")
    return {
        "n": len(ms),
        "p50_ms": round(statistics.median(ms), 2),
        "p95_ms": round(q[94], 2),
        "mean_ms": round(statistics.fmean(ms), 2),
        "max_ms": round(max(ms), 2),
    }


def _timed(fn: Callable[[], httpx.Response], expect: tuple[int, ...]) -> float:
    t0 = time.perf_counter()
    r = fn()
    dt = (time.perf_counter() - t0) * 1000
    if r.status_code not in expect:
        raise RuntimeError(f"unexpected {r.status_code}: {r.text}")
    return dt


def latency(url: str, n: int) -> dict[str, Any]:
    """One client, sequential requests."""
    out: dict[str, Any] = {}
    with httpx.Client(base_url=url, timeout=60) as c:
        for i in range(5):  # warm the connection and the server's code paths
            c.post("/runs", json=scene(10_000_000 + i, "warm"))
        new = [_timed(lambda i=i: c.post("/runs", json=scene(i, "lat")), (201,)) for i in range(n)]
        out["submit_new"] = _stats(new)
        old = [_timed(lambda i=i: c.post("/runs", json=scene(i, "lat")), (200,)) for i in range(n)]
        out["submit_archived"] = _stats(old)
        ids = [r["run_id"] for r in c.get("/runs", params={"name": "lat"}).json()["runs"]]
        out["get_run"] = _stats([_timed(lambda r=r: c.get(f"/runs/{r}"), (200,)) for r in ids])
        out["list_50"] = _stats(
            [_timed(lambda: c.get("/runs", params={"limit": 50}), (200,)) for _ in range(n)]
        )
    return out


def concurrent(
    url: str, clients: int, per_client: int, distinct: int | None, tag: str, offset: int
) -> Any:
    """``clients`` threads, each submitting ``per_client`` scenes then reading each run."""
    added = [0]
    lock = threading.Lock()

    def work(c: int) -> None:
        with httpx.Client(base_url=url, timeout=120) as client:
            for k in range(per_client):
                i = offset + ((c * 7 + k * 3) % distinct if distinct else c * per_client + k)
                r = client.post("/runs", json=scene(i, tag))
                r.raise_for_status()
                client.get(f"/runs/{r.json()['run_id']}").raise_for_status()
                with lock:
                    added[0] += r.json()["added"]

    t0 = time.perf_counter()
    with ThreadPoolExecutor(clients) as pool:
        list(pool.map(work, range(clients)))
    wall = time.perf_counter() - t0
    n = clients * per_client
    return {
        "clients": clients,
        "submissions": n,
        "distinct_scenes": distinct or n,
        "new_runs": added[0],
        "wall_s": round(wall, 3),
        "requests_per_s": round(2 * n / wall, 1),
        "submissions_per_s": round(n / wall, 1),
        "new_runs_per_s": round(added[0] / wall, 1),
    }


def job(url: str, n: int) -> dict[str, Any]:
    """A background job of ``n`` new scenes: submit, poll until done."""
    with httpx.Client(base_url=url, timeout=60) as c:
        t0 = time.perf_counter()
        r = c.post(
            "/jobs", json={"name": "bench", "scenes": [scene(300_000 + i, "job") for i in range(n)]}
        )
        r.raise_for_status()
        job_id = r.json()["job_id"]
        while (status := c.get(f"/jobs/{job_id}").json())["status"] in ("queued", "running"):
            time.sleep(0.02)
        wall = time.perf_counter() - t0
    if status["status"] != "done" or status["done"] != n:
        raise RuntimeError(f"job ended {status}")
    return {"scenes": n, "wall_s": round(wall, 3), "runs_per_s": round(n / wall, 1)}


def markdown(res: dict[str, Any]) -> str:
    m = res["machine"]
    lines = [
        "# Service latency and throughput",
        "",
        f"`python -m benchmarks.service` on {m['cpus']} CPU(s), {m['platform']}, Python "
        f"{m['python']}; load average before {m['load_before']}, after {m['load_after']}. "
        "Summary-only scenes (closed-form solver: the physics is a small part of a request); "
        "a new run is answered once its segment is written and fsynced and registered in the "
        "index (SQLite, synchronous=FULL); the runs of concurrent requests share one segment "
        "(group commit), a lone request's run has a segment of its own.",
        "",
        "## One client, sequential requests",
        "",
        "| request | n | p50 (ms) | p95 (ms) | mean (ms) | max (ms) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    names = {
        "submit_new": "POST /runs, new scene",
        "submit_archived": "POST /runs, already archived",
        "get_run": "GET /runs/{id}",
        "list_50": "GET /runs?limit=50",
    }
    for key, label in names.items():
        s = res["latency"][key]
        row = f"| {label} | {s['n']} | {s['p50_ms']} | {s['p95_ms']} | {s['mean_ms']} |"
        lines.append(f"{row} {s['max_ms']} |")
    lines += [
        "",
        "## Concurrent clients (each submission followed by a GET of the run)",
        "",
        "| mix | clients | submissions | distinct | wall (s) | requests/s | new runs/s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for key, label in (("all_new", "every scene new"), ("duplicated", "each scene ~5x")):
        c = res["concurrent"][key]
        lines.append(
            f"| {label} | {c['clients']} | {c['submissions']} | {c['distinct_scenes']} | "
            f"{c['wall_s']} | {c['requests_per_s']} | {c['new_runs_per_s']} |"
        )
    j = res["job"]
    lines += [
        "",
        f"Background job (`POST /jobs`, simulated in the server process): {j['scenes']} scenes "
        f"in {j['wall_s']} s = {j['runs_per_s']} runs/s.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--requests", type=int, default=200)
    ap.add_argument("--clients", type=int, default=16)
    ap.add_argument("--per-client", type=int, default=20)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = ap.parse_args()

    import bowlrec
    from bowlrec.spec import Scene

    bowlrec.simulate(Scene.model_validate(scene(0, "warm")))  # compile into numba's cache
    load_before = [round(x, 2) for x in os.getloadavg()]
    with tempfile.TemporaryDirectory() as tmp, server(Path(tmp) / "archive") as url:
        res: dict[str, Any] = {"latency": latency(url, args.requests)}
        res["concurrent"] = {
            "all_new": concurrent(url, args.clients, args.per_client, None, "new", 100_000),
            "duplicated": concurrent(
                url,
                args.clients,
                args.per_client,
                args.clients * args.per_client // 5,
                "dup",
                200_000,
            ),
        }
        res["job"] = job(url, args.requests)
    res["machine"] = {
        "cpus": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "load_before": load_before,
        "load_after": [round(x, 2) for x in os.getloadavg()],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "service.json").write_text(json.dumps(res, indent=2) + "\n")
    (args.out / "service.md").write_text(markdown(res))
    print(markdown(res))


if __name__ == "__main__":
    main()
