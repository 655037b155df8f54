"""``POST /runs`` against ``GET /health`` with 16 clients, for 1, 2 and 3 server processes.

    python -m benchmarks.service_runs [--rounds 5] [--per-client 40] [--workers 1,2,3]
                                      [--out benchmarks/results]

One ``bowlrec serve --workers N`` per N (N = 1: the single process), each on a fresh archive,
all started before the first measurement and kept running. Each round measures every server
in turn (the order rotates from round to round, so load on the shared machine falls on each
alike): 16 concurrent clients (httpx, one thread and one connection each) post
``--per-client`` new summary-only scenes each (every run simulated, sealed, fsynced and
indexed before its answer), then the same clients ``GET /health`` as often on the same
server. The ratio of a round is its POST rate over its GET rate; the table gives the median
over the rounds (and the range), and the runs per segment (how many runs a group commit
sealed together). The target (issue 32): ``POST /runs`` at >= 50 % of ``GET /health``.

Writes ``service_runs.json`` and ``service_runs.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from .pipeline import _load
from .service import server

CLIENTS = 16
#: the target: POST /runs at this share of GET /health (%)
TARGET_PCT = 50.0


def _segments(archive: Path) -> int:
    from bowlrec.archive import Archive

    return int(Archive(archive, create=False).info()["segments"])


def measure(workers: list[int], rounds: int, per_client: int) -> dict[str, Any]:
    raw: dict[int, list[dict[str, float]]] = {n: [] for n in workers}
    first = 0
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        urls = {}
        for n in workers:
            archive = Path(tmp) / f"archive-{n}"
            urls[n] = stack.enter_context(server(archive, "--workers", str(n)))
            _load(urls[n], CLIENTS, 5, new_scene=True, first=first)  # every worker warm
            first += CLIENTS * 5
        warm = {n: _segments(Path(tmp) / f"archive-{n}") for n in workers}
        for r in range(rounds):
            for n in workers[r % len(workers) :] + workers[: r % len(workers)]:
                runs = _load(urls[n], CLIENTS, per_client, new_scene=True, first=first)
                first += CLIENTS * per_client
                health = _load(urls[n], CLIENTS, per_client, new_scene=False)
                raw[n].append(
                    {
                        "runs_per_s": runs["per_s"],
                        "health_per_s": health["per_s"],
                        "pct": 100 * runs["per_s"] / health["per_s"],
                    }
                )
        segments = {n: _segments(Path(tmp) / f"archive-{n}") - warm[n] for n in workers}
    rows = []
    for n in workers:
        pct = [x["pct"] for x in raw[n]]
        rows.append(
            {
                "workers": n,
                "runs_per_s": statistics.median(x["runs_per_s"] for x in raw[n]),
                "health_per_s": statistics.median(x["health_per_s"] for x in raw[n]),
                "pct_of_health": statistics.median(pct),
                "pct_min": min(pct),
                "pct_max": max(pct),
                "runs_per_segment": rounds * CLIENTS * per_client / max(1, segments[n]),
                "met": statistics.median(pct) >= TARGET_PCT,
            }
        )
    return {
        "clients": CLIENTS,
        "rounds": rounds,
        "per_client": per_client,
        "target_pct": TARGET_PCT,
        "rows": rows,
        "raw": {str(n): v for n, v in raw.items()},
        "machine": {
            "platform": platform.platform(),
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "load_before": [round(x, 2) for x in load_before],
            "load_after": [round(x, 2) for x in os.getloadavg()],
        },
        "date": time.strftime("%Y-%m-%d"),
    }


def _f(x: float, digits: int = 0) -> str:
    return f"{x:,.{digits}f}"


def markdown(d: dict[str, Any]) -> str:
    best = max(d["rows"], key=lambda r: r["pct_of_health"])
    lines = [
        "# Service: POST /runs against GET /health, 1 to N server processes",
        "",
        "Written by `python -m benchmarks.service_runs` "
        f"({d['date']}, {d['machine']['cpus']} cores, shared: load average "
        f"{d['machine']['load_before'][0]:.1f} before, {d['machine']['load_after'][0]:.1f} "
        "after).",
        "",
        f"{d['clients']} concurrent clients (httpx, one thread and one connection each, in one "
        f"process on the same machine), {d['per_client']} requests each: `POST /runs` of new "
        "summary-only scenes (each simulated, sealed, fsynced and indexed before its answer), "
        "then `GET /health` of the same server. `bowlrec serve --workers N` (N = 1: one "
        "process; N > 1: N worker processes and the supervisor, which group-commits every "
        f"worker's runs). Medians of {d['rounds']} rounds; the servers measured in turn in "
        "each round, the order rotating.",
        "",
        "| server processes | POST /runs (requests/s) | GET /health (requests/s) "
        "| POST / GET (median, min..max) | runs per segment | >= 50 % |",
        "|---:|---:|---:|---:|---:|---|",
    ]
    for r in d["rows"]:
        lines.append(
            f"| {r['workers']} | {_f(r['runs_per_s'])} | {_f(r['health_per_s'])} "
            f"| {_f(r['pct_of_health'], 1)} % ({_f(r['pct_min'], 1)}..{_f(r['pct_max'], 1)}) "
            f"| {_f(r['runs_per_segment'], 1)} | {'yes' if r['met'] else 'no'} |"
        )
    verdict = "met" if best["met"] else "missed"
    lines += [
        "",
        f"Target (issue 32): `POST /runs` at >= {d['target_pct']:g} % of `GET /health` with "
        f"{d['clients']} clients: {verdict} (best: {best['workers']} process(es), "
        f"{_f(best['pct_of_health'], 1)} %).",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--per-client", type=int, default=40)
    parser.add_argument("--workers", default="1,2,3")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    workers = [int(x) for x in args.workers.split(",")]
    d = measure(workers, args.rounds, args.per_client)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "service_runs.json").write_text(json.dumps(d, indent=2) + "\n")
    (args.out / "service_runs.md").write_text(markdown(d))
    print(markdown(d))


if __name__ == "__main__":
    main()
