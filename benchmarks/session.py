"""The example session: what it costs, how the lane changes, and how the shots drift.

    python -m benchmarks.session [--out benchmarks/results] [--update-docs]

Plays ``examples/session/league-night.yaml`` (4 bowlers x 3 games on the house shot: 12 games
on one lane) into a new archive, then plays it again (every shot read back from the archive:
the cost of resuming). Reports the time per shot and where it goes (the kernel's wall time is
stored with every run), the oil on the lane and in the heads (the first 15 ft) after every
game, the oil left in the heads' area of play (the boards the shots' tracks cover: per 1 ft row,
the cells covered at least half as much as the row's most covered one, as in
``benchmarks.oil_grid``), and the drift of each bowler's breakpoint, entry board and entry angle
game by game. ``--update-docs`` writes the session's figures to ``docs/images/session-oil.png``
and ``docs/images/session-drift.png``. Writes ``session.json`` and ``session.md``; the machine's
load is recorded.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from bowlrec.archive import Archive
from bowlrec.bowling.oil import OilGrid
from bowlrec.bowling.oil_transfer import track_coverage
from bowlrec.session.records import oil_from_records
from bowlrec.session.runner import SessionResult, run_session
from bowlrec.session.spec import load_session

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "session" / "league-night.yaml"
HEADS_FT = 15.0


def _heads_ul(grid: OilGrid, cells: np.ndarray | None = None) -> float:
    rows = grid.x_edges_ft[:-1] < HEADS_FT
    vol = grid.volume_ul[rows]
    return float(vol.sum() if cells is None else vol[cells[rows]].sum())


def _area_of_play(result: SessionResult, archive: Archive) -> np.ndarray:
    """Cells of the session's grid the tracks cover at least half as much as their row's most
    covered cell (every shot's track, from its archived samples)."""
    grid = result.fresh
    width = result.spec.bowlers[0].scene.lane.width_m
    total = np.zeros_like(grid.volume_ul)
    for row in result.rows:
        pos = archive.load(row.run_id).trajectory.position_m
        area, _ = track_coverage(
            grid,
            pos[:, 0],
            pos[:, 1],
            lane_width_m=width,
            track_width_m=result.spec.transfer.track_width_m,
        )
        total += area
    peak = total.max(axis=1, keepdims=True)
    return (total > 0.0) & (total >= 0.5 * peak)


def _drift(result: SessionResult) -> list[dict[str, Any]]:
    groups: dict[tuple[str, int], list[Any]] = defaultdict(list)
    for r in result.rows:
        groups[(r.bowler, r.game)].append(r)
    order = [b.name for b in result.spec.bowlers]
    out = []
    for (bowler, game), rows in sorted(
        groups.items(), key=lambda k: (order.index(k[0][0]), k[0][1])
    ):

        def mean(name: str, rows: list[Any] = rows) -> float | None:
            values = [getattr(r, name) for r in rows if getattr(r, name) is not None]
            return statistics.fmean(values) if values else None

        out.append(
            {
                "bowler": bowler,
                "game": game,
                "shots": len(rows),
                "strikes": sum(r.pocket for r in rows if r.ball == 1),
                "first_balls": sum(r.ball == 1 for r in rows),
                "breakpoint_board": mean("breakpoint_board"),
                "breakpoint_ft": mean("breakpoint_ft"),
                "entry_board": mean("entry_board"),
                "entry_angle_deg": mean("entry_angle_deg"),
            }
        )
    return out


def _per_game(result: SessionResult, archive: Archive, play: np.ndarray) -> list[dict[str, Any]]:
    fresh = result.fresh
    out = [
        {
            "game": 0,
            "shots": 0,
            "lane_ul": float(fresh.volume_ul.sum()),
            "heads_ul": _heads_ul(fresh),
            "heads_play_ul": _heads_ul(fresh, play),
        }
    ]
    for game in range(1, result.spec.games + 1):
        last = [r for r in result.rows if r.game == game][-1]
        grid = oil_from_records(archive.load(last.run_id).records["oil"])
        out.append(
            {
                "game": game,
                "shots": last.shot,
                "lane_ul": float(grid.volume_ul.sum()),
                "heads_ul": _heads_ul(grid),
                "heads_play_ul": _heads_ul(grid, play),
            }
        )
    return out


def run() -> tuple[dict[str, Any], SessionResult]:
    spec = load_session(EXAMPLE)
    load_before = [round(x, 2) for x in os.getloadavg()]
    with tempfile.TemporaryDirectory() as tmp:
        archive = Archive(Path(tmp) / "a")
        result = run_session(spec, archive)  # first: compiles nothing new (warm cache)
        t0 = time.perf_counter()
        again = run_session(spec, archive)
        resume_s = time.perf_counter() - t0
        assert again.resumed == len(result.rows) and again.simulated == 0
        rows = archive.rows([r.run_id for r in result.rows])
        kernel_s = sum(float(rows[r.run_id]["wall_time_s"]) for r in result.rows)
        play = _area_of_play(result, archive)
        games = _per_game(result, archive, play)
        archive.close()
    n = len(result.rows)
    data = {
        "session": str(EXAMPLE.relative_to(ROOT)),
        "session_id": result.session_id,
        "shots": n,
        "games_on_the_lane": spec.games * len(spec.bowlers),
        "seconds": result.seconds,
        "ms_per_shot": 1e3 * result.seconds / n,
        "kernel_ms_per_shot": 1e3 * kernel_s / n,
        "resume_seconds": resume_s,
        "resume_ms_per_shot": 1e3 * resume_s / n,
        "aims": result.aims,
        "oil_by_game": games,
        "heads_play_cells": int(play[result.fresh.x_edges_ft[:-1] < HEADS_FT].sum()),
        "drift": _drift(result),
        "machine": {
            "platform": platform.platform(),
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "python": platform.python_version(),
        },
        "loadavg_before": load_before,
        "loadavg_after": [round(x, 2) for x in os.getloadavg()],
    }
    return data, result


def _f(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def markdown(d: dict[str, Any]) -> str:
    g0 = d["oil_by_game"][0]
    lines = [
        "# The example session",
        "",
        f"`python -m benchmarks.session` on {d['machine']['cores']} cores "
        f"({d['machine']['cpu']}, Python {d['machine']['python']}); load average before "
        f"{d['loadavg_before']}, after {d['loadavg_after']}.",
        "",
        f"`{d['session']}`: {d['shots']} shots, {d['games_on_the_lane']} games on one lane.",
        "",
        "| | value |",
        "|---|---|",
        f"| played (simulated, transferred, archived) | {d['seconds']:.2f} s, "
        f"{d['ms_per_shot']:.1f} ms per shot |",
        f"| of which the kernel (stored wall time) | {d['kernel_ms_per_shot']:.1f} ms per shot |",
        f"| played again (every shot read back) | {d['resume_seconds']:.2f} s, "
        f"{d['resume_ms_per_shot']:.1f} ms per shot |",
        "",
        "## The oil, game by game",
        "",
        f"Heads: the first {HEADS_FT:g} ft. Area of play in the heads: the "
        f"{d['heads_play_cells']} cells (1 ft x 1 board) the tracks cover at least half as "
        "much as their row's most covered cell.",
        "",
        "| after game | shots | lane (mL) | kept | heads (µL) | kept | heads, area of play (µL) "
        "| kept |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for g in d["oil_by_game"]:
        lines.append(
            f"| {g['game'] or 'fresh'} | {g['shots']} | {g['lane_ul'] / 1e3:.2f} | "
            f"{100 * g['lane_ul'] / g0['lane_ul']:.1f} % | {g['heads_ul']:.0f} | "
            f"{100 * g['heads_ul'] / g0['heads_ul']:.1f} % | {g['heads_play_ul']:.0f} | "
            f"{100 * g['heads_play_ul'] / g0['heads_play_ul']:.1f} % |"
        )
    lines += [
        "",
        "## Drift, game by game (means over each bowler's shots)",
        "",
        "| bowler | game | shots | strikes | breakpoint board | breakpoint (ft) | entry board "
        "| entry angle (deg) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in d["drift"]:
        lines.append(
            f"| {r['bowler']} | {r['game']} | {r['shots']} | {r['strikes']}/{r['first_balls']} "
            f"| {_f(r['breakpoint_board'])} | {_f(r['breakpoint_ft'], 1)} | "
            f"{_f(r['entry_board'])} | {_f(r['entry_angle_deg'])} |"
        )
    lines += ["", "Aiming on the fresh lane:", ""]
    lines += [f"- {name}: {msg}" for name, msg in d["aims"].items()]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--update-docs", action="store_true")
    args = ap.parse_args(argv)
    data, result = run()
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "session.json").write_text(json.dumps(data, indent=1) + "\n")
    (args.out / "session.md").write_text(markdown(data))
    if args.update_docs:
        from bowlrec.cli.session import write_outputs

        with tempfile.TemporaryDirectory() as tmp:
            write_outputs(result, Path(tmp))
            images = ROOT / "docs" / "images"
            for stem in ("oil", "drift"):
                (images / f"session-{stem}.png").write_bytes(
                    (Path(tmp) / f"{stem}.png").read_bytes()
                )
    print(markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
