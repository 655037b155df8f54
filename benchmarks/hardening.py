"""Bounded work under hostile input: what hostile inputs cost a real server, and a
10,000,000-run job from the command line.

    python -m benchmarks.hardening [--out benchmarks/results] [--stop-at 1000000]

1. **The service** (``bowlrec serve`` on 127.0.0.1, a fresh archive): each input that, without
   bowlrec's input limits, would take 1-3 GB of memory is sent once; for each, the status, the
   seconds until the answer, and the server's peak resident memory (``VmHWM`` from /proc)
   after it and how much the request raised it. The targets: every one is answered within
   1 s, refused (4xx) or accepted as a background job (the allowed large jobs), and no refused
   input raises the server's peak memory by more than 100 MB.
2. **A 10,000,000-run summary-only job** (``bowlrec batch JOB --no-archive --out t.jsonl -j 2``,
   the case-16 benchmark job with n = 10,000,000): seconds from launching the command until
   the first table row is written, and the resident memory of the command and its workers at
   100,000 and at ``--stop-at`` rows (then it is interrupted with SIGINT). Targets: the job
   starts within 1 s (measured in-process as the time until the first chunk is submitted:
   ``run_job``'s first progress report), and the memory stays within +-10 % from 100,000 runs
   to 1,000,000 runs.
3. **The largest recording allowed** (2,000,000 samples at ``record: rate``): its peak memory in
   one process, the per-simulation bound the service's memory is a multiple of.

Writes ``hardening.json`` and ``hardening.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx

from benchmarks.pipeline import _rss_mb
from benchmarks.service import server

ROOT = Path(__file__).resolve().parents[1]
JOB = ROOT / "benchmarks" / "jobs" / "case16-summary.json"


def _peak_mb(pid: int) -> float:
    """Peak resident memory of one process (VmHWM, MB)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmHWM for {pid}")


def _server_pid(port: str) -> int:
    """The pid of the process listening on ``port`` (the server under test)."""
    out = subprocess.run(["ss", "-Htlnp", f"sport = :{port}"], capture_output=True, text=True)
    for part in out.stdout.split("pid=")[1:]:
        return int(part.split(",")[0])
    raise RuntimeError(f"no process listens on {port}")


def _chunks(total: int, size: int = 1 << 20) -> Iterator[bytes]:
    sent = 0
    while sent < total:
        n = min(size, total - sent)
        sent += n
        yield b" " * n


def _job(**sweep: Any) -> dict[str, Any]:
    return {"name": "hostile", "sweep": sweep, "record": "summary"}


HOSTILE: list[tuple[str, str, Any]] = [
    (
        "POST /runs record_dt_s = 1e-300",
        "/runs",
        {"options": {"record": "rate", "record_dt_s": 1e-300}},
    ),
    (
        "POST /runs record_dt_s = 1e-8",
        "/runs",
        {"options": {"record": "rate", "record_dt_s": 1e-8}},
    ),
    (
        "POST /runs record_dt_s = 1e-6",
        "/runs",
        {"options": {"record": "rate", "record_dt_s": 1e-6}},
    ),
    ("POST /runs omega 1e300", "/runs", {"delivery": {"omega_radps": [0, 1e300, 0]}}),
    (
        "POST /jobs grid of 1e8 points",
        "/jobs",
        _job(
            kind="grid",
            axes={
                "delivery.speed_mps": {"start": 6, "stop": 9, "num": 10_000},
                "delivery.takeoff_angle_deg": {"start": -2, "stop": 2, "num": 10_000},
            },
        ),
    ),
    (
        "POST /jobs random n = 10,000,000 (accepted, then cancelled)",
        "/jobs",
        _job(
            kind="random", n=10_000_000, seed=1, axes={"delivery.speed_mps": {"low": 6, "high": 9}}
        ),
    ),
    (
        "POST /jobs random n = 200,000 (accepted, then cancelled)",
        "/jobs",
        _job(kind="random", n=200_000, seed=2, axes={"delivery.speed_mps": {"low": 6, "high": 9}}),
    ),
    (
        "POST /jobs 100,000 explicit scenes (accepted, then cancelled)",
        "/jobs",
        {"name": "explicit", "scenes": [{"delivery": {"speed_mps": 7.5}}] * 100_000},
    ),
    ("POST /runs nested 100,000 deep", "/runs", "[" * 100_000 + "]" * 100_000),
    ("POST /runs 200 MB chunked body", "/runs", 200 * 1024 * 1024),
]


def service(tmp: Path) -> list[dict[str, Any]]:
    rows = []
    with server(tmp / "archive") as url:
        pid = _server_pid(url.rsplit(":", 1)[1])
        client = httpx.Client(base_url=url, timeout=120)
        client.post("/runs", json={"options": {"record": "summary"}})  # warm
        for label, path, body in HOSTILE:
            base = _peak_mb(pid)
            t0 = time.perf_counter()
            if isinstance(body, int):
                r = client.post(
                    path, content=_chunks(body), headers={"content-type": "application/json"}
                )
            elif isinstance(body, str):
                r = client.post(path, content=body, headers={"content-type": "application/json"})
            else:
                r = client.post(path, json=body)
            seconds = time.perf_counter() - t0
            if r.status_code == 202:
                client.post(f"/jobs/{r.json()['job_id']}/cancel")
            detail = (
                r.json().get("detail")
                if r.headers.get("content-type", "").startswith("application/json")
                else None
            )
            rows.append(
                {
                    "input": label,
                    "status": r.status_code,
                    "seconds": seconds,
                    "peak_mb": _peak_mb(pid),
                    "growth_mb": _peak_mb(pid) - base,
                    "detail": detail if isinstance(detail, str) else None,
                }
            )
    return rows


def ten_million(tmp: Path, stop_at: int) -> dict[str, Any]:
    """The CLI on a 10,000,000-run job: first row, and memory at 100,000 and ``stop_at`` rows."""
    data = json.loads(JOB.read_text())
    data["sweep"]["n"] = 10_000_000
    data["name"] = "ten-million"
    job = tmp / "ten-million.json"
    job.write_text(json.dumps(data))
    out = tmp / "t.jsonl"
    cmd = [
        sys.executable,
        "-m",
        "bowlrec.cli",
        "batch",
        str(job),
        "--no-archive",
        "--out",
        str(out),
        "-j",
        "2",
        "-q",
    ]
    t0 = time.perf_counter()
    err = (tmp / "stderr.txt").open("wb")
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=err)
    marks: dict[str, Any] = {}
    rows = 0
    pos = 0
    try:
        while proc.poll() is None:
            # the table is written to a temporary file beside it, renamed when complete
            parts = list(tmp.glob(f".{out.name}.*.part"))
            if parts:
                with parts[0].open("rb") as fh:
                    fh.seek(pos)
                    chunk = fh.read()
                pos += len(chunk)
                rows += chunk.count(b"\n")
                if rows and "first_row_s" not in marks:
                    marks["first_row_s"] = time.perf_counter() - t0
                if rows >= 100_000 and "rss_100k_mb" not in marks:
                    marks["rss_100k_mb"] = _rss_mb(proc.pid)
                    marks["rows_100k"] = rows
                if rows >= stop_at:
                    marks["rss_stop_mb"] = _rss_mb(proc.pid)
                    marks["rows_stop"] = rows
                    marks["stop_s"] = time.perf_counter() - t0
                    break
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(60)
        except subprocess.TimeoutExpired:
            proc.kill()
    err.close()
    if "rss_stop_mb" not in marks:
        raise RuntimeError(f"the batch stopped early: {(tmp / 'stderr.txt').read_text()}")
    marks["rss_change_pct"] = 100 * (marks["rss_stop_mb"] / marks["rss_100k_mb"] - 1)
    marks["runs_per_s"] = marks["rows_stop"] / marks["stop_s"]
    return marks


def in_process_start() -> float:
    """Seconds from calling ``run_job`` on the 10,000,000-run job until its first progress
    report (the job checked and its first chunks submitted)."""
    from bowlrec.batch import JobSpec, run_job

    data = json.loads(JOB.read_text())
    data["sweep"]["n"] = 10_000_000
    job = JobSpec.model_validate(data)
    cancel = threading.Event()
    seen: list[float] = []
    t0 = time.perf_counter()

    def progress(p: Any) -> None:
        if not seen:
            seen.append(time.perf_counter() - t0)
        cancel.set()

    run_job(job, None, workers=2, progress=progress, cancel=cancel, sink=lambda t: None)
    return seen[0]


LARGEST = """
import resource, json, bowlrec
from bowlrec.spec import Scene
bowlrec.simulate(Scene.model_validate({"options": {"record": "rate"}}))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
s = Scene.model_validate({
    "lane": {"length_m": 10000, "friction": {"kind": "constant", "mu": 0.2}},
    "delivery": {"speed_mps": 1.0, "omega_radps": [0, 9.2166, 0]},
    "options": {"record": "rate", "record_dt_s": 0.005, "max_time_s": 10000}})
tr = bowlrec.simulate(s)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"samples": len(tr.t_s), "before_mb": before / 1024, "after_mb": after / 1024}))
"""


def largest_recording() -> dict[str, Any]:
    out = subprocess.run(
        [sys.executable, "-c", LARGEST], capture_output=True, text=True, check=True
    )
    d: dict[str, Any] = json.loads(out.stdout)
    d["growth_mb"] = d["after_mb"] - d["before_mb"]
    return d


def markdown(d: dict[str, Any]) -> str:
    lines = [
        "# Bounded work under hostile input",
        "",
        f"Measured {d['date']} on {d['machine']} (load average {d['load_before']} before, "
        f"{d['load_after']} after) by `python -m benchmarks.hardening`.",
        "",
        "## The service",
        "",
        "Each input once, in this order, to one `bowlrec serve` on 127.0.0.1; the server's peak "
        "resident memory is VmHWM after the request.",
        "",
        "| input | status | seconds | server peak after (MB) | raised by (MB) |",
        "|---|---|---|---|---|",
    ]
    for r in d["service"]:
        lines.append(
            f"| {r['input']} | {r['status']} | {r['seconds']:.3f} | {r['peak_mb']:.0f} | "
            f"{r['growth_mb']:+.0f} |"
        )
    refused = [r for r in d["service"] if 400 <= r["status"] < 500]
    worst = max(r["growth_mb"] for r in refused)
    slowest = max(r["seconds"] for r in d["service"])
    ok = all(400 <= r["status"] < 500 or r["status"] == 202 for r in d["service"])
    lines += [
        "",
        f"Every input refused or queued: **{'yes' if ok else 'no'}**; slowest answer "
        f"{slowest:.3f} s (target <= 1 s: **{'met' if slowest <= 1 else 'missed'}**); the most "
        f"a refused input raised the server's peak memory: {worst:+.0f} MB (target <= 100 MB: "
        f"**{'met' if worst <= 100 else 'missed'}**). The accepted jobs are allowed inputs; "
        "their memory is the job's spec, held while it runs.",
        "",
        "## A 10,000,000-run job",
        "",
    ]
    t = d["ten_million"]
    lines += [
        "`bowlrec batch` on the case-16 job with n = 10,000,000, "
        "`--no-archive --out t.jsonl -j 2`: `run_job` reported its first progress "
        f"{d['in_process_start_s']:.3f} s after it was called (target <= 1 s: "
        f"**{'met' if d['in_process_start_s'] <= 1 else 'missed'}**); from the shell, "
        f"the first row was written {t['first_row_s']:.2f} s after the command was launched "
        "(interpreter, imports, two workers loading the compiled kernels). The command and its "
        f"workers held {t['rss_100k_mb']:.0f} MB at {t['rows_100k']:,} rows and "
        f"{t['rss_stop_mb']:.0f} MB at {t['rows_stop']:,} rows ({t['rss_change_pct']:+.1f} %; "
        f"target within +-10 %: **{'met' if abs(t['rss_change_pct']) <= 10 else 'missed'}**), "
        f"{t['runs_per_s']:,.0f} runs/s to that point.",
        "",
        "## The largest recording allowed",
        "",
    ]
    g = d["largest_recording"]
    lines += [
        f"{g['samples']:,} samples (`record: rate`, max_time_s / record_dt_s = 2,000,000): the "
        f"process's peak memory grew by {g['growth_mb']:.0f} MB, about "
        f"{g['growth_mb'] * 1e6 / g['samples']:.0f} bytes per sample (the kernel's buffer as it "
        "grows, and the trajectory's arrays). A server simulating k recorded runs at once can "
        "need k times this.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--stop-at", type=int, default=1_000_000)
    args = ap.parse_args()
    d: dict[str, Any] = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": (
            f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
        ),
        "load_before": ", ".join(f"{x:.2f}" for x in os.getloadavg()),
    }
    with tempfile.TemporaryDirectory() as tmp:
        d["service"] = service(Path(tmp))
        d["largest_recording"] = largest_recording()
        d["in_process_start_s"] = in_process_start()
        d["ten_million"] = ten_million(Path(tmp), args.stop_at)
    d["load_after"] = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    d["peak_self_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "hardening.json").write_text(json.dumps(d, indent=2) + "\n")
    (args.out / "hardening.md").write_text(markdown(d))
    print(markdown(d))


if __name__ == "__main__":
    main()
