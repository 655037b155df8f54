"""Oil transfer: calibration of the pickup fraction, and what the oil grid's resolution costs.

    python -m benchmarks.oil_grid [--tracks 300] [--seed 0] [--out benchmarks/results]

**Tracks.** A right-hander's house shot (``examples/bowler/house-shot-right.json``: a tweener's
17.5 mph, 350 rpm, 45 deg rotation on ``house_shot_approx``, laydown board 17.0 over board 10.7
at the arrows, breaking on board 5 at 40 ft) repeated with the ``pro`` release scatter
(:mod:`bowlrec.bowling.variance`), each repeat simulated with its samples every 5 ms: the
contact point's path (x, y). The tracks are simulated once on the fresh lane and applied shot
after shot; the wear's feedback on the tracks (a worn lane hooks a little earlier) is left out
of the calibration and measured separately (``feedback``: the same shots re-simulated on the
lane as it is before each).

**Calibration** (``docs/oil-transition.md``): ``pickup_fraction`` is solved (bisection) so that
the oil removed from the area of play over the pattern's length is 40 % after 4.5 games of
17 deliveries (77 shots), Kegel's "over 40 percent ... within about 4-5 games per lane"; the
other parameters are the model's argued defaults. Area of play: in each 1 ft row from the foul
line to the end of the oil, the boards whose mean coverage by the shots is at least half the
row's largest (the footprint's full width at half maximum); removed: the net loss of oil from
those cells (lifted less what carrydown lays back in them). Then the calibrated model is run to
13.5 games (230 shots) and compared with "the heads keep about 50 % after 12-15 games".

**Resolution cost.** The lane after 40 shots, worn on a 0.25 ft x 0.25 board grid (the
reference), is coarsened to other cells (volume conserved) and turned into friction with the
session mapping (the calibrated mapping, docs/calibration.md). For 60 repeats of the shot: the
kernel time per delivery (summary only and recorded at 5 ms; best of 3), the zone events, the
slide <-> roll changes, the right-hand sides, and the entry board and breakpoint against the
reference grid. Also μ quantised to a few levels (on the 1 ft x 1 board grid) before the grid
is made minimal. Writes ``oil_grid.json`` and ``oil_grid.md``; the machine's load is
recorded.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from bowlrec.bowling.oil import OilGrid, preset
from bowlrec.bowling.oil_friction import OilFrictionMapping, grid_friction
from bowlrec.bowling.oil_transfer import (
    TransferModel,
    absorb_between_shots,
    apply_track,
    resample_grid,
    session_oil_grid,
    track_coverage,
)
from bowlrec.bowling.scene import BowlerScene, Shot
from bowlrec.bowling.variance import PRESETS, ReleaseScatter
from bowlrec.core.codes import RECORD_RATE, RECORD_SUMMARY
from bowlrec.core.solver import kernel_call, solve
from bowlrec.spec import Lane
from bowlrec.spec.friction import GridFriction
from bowlrec.spec.friction_grid import simplify_grid

ROOT = Path(__file__).resolve().parents[1]
PATTERN = "house_shot_approx"
DELIVERIES_PER_GAME = 17
KEGEL_GAMES = 4.5
KEGEL_REMOVED = 0.40
HEADS_GAMES = 13.5
HEADS_FT = 15.0
RECORD_DT_S = 0.005
#: the reference cells (the lane is worn on them) and the cells compared with it (ft, boards)
REFERENCE_CELL = (0.25, 0.25)
CELLS = [REFERENCE_CELL, (0.5, 0.5), (1.0, 1.0), (2.0, 1.0), (3.0, 1.0), (1.0, 3.0), (5.0, 5.0)]


@dataclass(frozen=True)
class Track:
    """One simulated delivery: the center's path (m) and what a session reports of it."""

    x_m: np.ndarray
    y_m: np.ndarray
    outcome: str
    entry_board: float
    breakpoint_board: float
    breakpoint_ft: float
    zone_events: int
    phase_changes: int
    n_rhs: int


def house_scene() -> BowlerScene:
    """The house-shot example: a tweener on the rule-of-31 line of ``PATTERN``."""
    path = Path(__file__).resolve().parents[1] / "examples" / "bowler" / "house-shot-right.json"
    scene = BowlerScene.model_validate_json(path.read_text())
    assert scene.pattern == PATTERN
    return scene


def session_mapping(fresh: OilGrid, width_m: float) -> OilFrictionMapping:
    """The sessions' mapping: the calibrated one (its power ramp below the calibrated film
    makes a worn film grip more); ``fresh`` and ``width_m`` do not enter it."""
    del fresh, width_m
    return OilFrictionMapping()


def _lane(scene: BowlerScene, friction: GridFriction) -> Lane:
    return scene.lane.to_physical(friction)


def _releases(
    scene: BowlerScene, lane: Lane, scatter: ReleaseScatter, n: int, seed: int
) -> list[Any]:
    """``n`` scattered releases (as :func:`bowlrec.bowling.variance.release_scatter` draws
    them) of ``scene``'s delivery, the launch angle solved once on ``lane``."""
    shot = Shot(scene, lane=lane)
    d = scene.delivery
    launch = shot.launch_angle(d)
    rng = np.random.default_rng(seed)
    names = ("speed_mph", "rev_rate_rpm", "axis_rotation_deg", "axis_tilt_deg")
    draws = {k: getattr(d, k) + getattr(scatter, k) * rng.standard_normal(n) for k in names}
    draws["launch_angle_deg"] = launch + scatter.launch_angle_deg * rng.standard_normal(n)
    draws["laydown_board"] = np.clip(
        d.laydown_board + scatter.laydown_board * rng.standard_normal(n), 0.5, 39.5
    )
    base = {**d.model_dump(), "target_board_at_arrows": None}
    out = []
    for i in range(n):
        fields = {**base, **{k: float(v[i]) for k, v in draws.items()}}
        out.append(type(d).model_validate(fields))
    return out


def simulate(scene: BowlerScene, lane: Lane, release: Any) -> Track:
    """One release on ``lane``, recorded every 5 ms."""
    shot = Shot(scene, lane=lane)
    plan = shot.plan(release.to_physical(scene.lane), summary_only=False)
    traj = solve(replace(plan, record_mode=RECORD_RATE, record_dt_s=RECORD_DT_S))
    x, y = traj.position_m[:, 0].copy(), traj.position_m[:, 1].copy()
    k = int(np.argmin(y))
    board = scene.lane.y_to_board
    pins = traj.summary.outcome == "pins"
    return Track(
        x_m=x,
        y_m=y,
        outcome=traj.summary.outcome,
        entry_board=board(float(y[-1])) if pins else math.nan,
        breakpoint_board=board(float(y[k])),
        breakpoint_ft=float(x[k]) / 0.3048,
        zone_events=sum(e.kind == "zone" for e in traj.events),
        phase_changes=sum(e.kind in ("slide_to_roll", "roll_to_slide") for e in traj.events),
        n_rhs=traj.summary.n_rhs,
    )


def wear(
    grid: OilGrid, tracks: list[Track], model: TransferModel, width_m: float
) -> tuple[OilGrid, list[OilGrid], float]:
    """The tracks applied in order by one ball; (final grid, grid after each shot, oil
    unaccounted for in µL)."""
    load, absorbed_total, lane0 = 0.0, 0.0, float(grid.volume_ul.sum())
    after = []
    for t in tracks:
        grid, load, _ = apply_track(
            grid, t.x_m, t.y_m, lane_width_m=width_m, model=model, ball_load_ul=load
        )
        load, absorbed = absorb_between_shots(load, model)
        absorbed_total += absorbed
        after.append(grid)
    imbalance = lane0 - float(grid.volume_ul.sum()) - load - absorbed_total
    return grid, after, imbalance


def area_of_play(grid: OilGrid, tracks: list[Track], model: TransferModel, width_m: float) -> Any:
    """Cells with mean coverage >= half their row's largest, rows up to the end of the oil."""
    cover = np.zeros_like(grid.volume_ul)
    cell = np.outer(np.diff(grid.x_edges_ft), np.diff(grid.board_edges))
    for t in tracks:
        area, _ = track_coverage(
            grid, t.x_m, t.y_m, lane_width_m=width_m, track_width_m=model.track_width_m
        )
        cover += area / cell
    peak = cover.max(axis=1, keepdims=True)
    mask = (cover >= 0.5 * peak) & (peak > 0)
    mask &= (grid.x_edges_ft[:-1] < grid.oil_end_ft)[:, None]
    return mask


def removed(before: OilGrid, after: OilGrid, mask: Any) -> float:
    b = float(before.volume_ul[mask].sum())
    return (b - float(after.volume_ul[mask].sum())) / b


def calibrate(fresh: OilGrid, tracks: list[Track], width_m: float) -> dict[str, Any]:
    n_kegel = round(KEGEL_GAMES * DELIVERIES_PER_GAME)
    shots = tracks[:n_kegel]
    base = TransferModel()
    mask = area_of_play(fresh, shots, base, width_m)

    def frac(p: float, model: TransferModel = base) -> float:
        final, _, _ = wear(fresh, shots, model.model_copy(update={"pickup_fraction": p}), width_m)
        return removed(fresh, final, mask)

    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if frac(mid) < KEGEL_REMOVED else (lo, mid)
    p = 0.5 * (lo + hi)
    model = base.model_copy(update={"pickup_fraction": p})
    sens = {}
    for k in (0.0, 0.01, 0.05):
        alt = base.model_copy(update={"carrydown_fraction": k})
        a, b = 0.0, 1.0
        for _ in range(30):
            m = 0.5 * (a + b)
            a, b = (m, b) if frac(m, alt) < KEGEL_REMOVED else (a, m)
        sens[f"carrydown {k:g}"] = 0.5 * (a + b)
    n_heads = round(HEADS_GAMES * DELIVERIES_PER_GAME)
    heads_shots = [tracks[i % len(tracks)] for i in range(n_heads)]
    final, after, imbalance = wear(fresh, heads_shots, model, width_m)
    heads = (fresh.x_edges_ft[:-1] < HEADS_FT)[:, None]
    full = np.ones_like(mask)
    curve = []
    for games in (1, 2, 3, 4.5, 6, 9, 12, 13.5):
        g = after[round(games * DELIVERIES_PER_GAME) - 1]
        curve.append(
            {
                "games": games,
                "removed_area_of_play": removed(fresh, g, mask),
                "kept_heads_area_of_play": 1.0 - removed(fresh, g, mask & heads),
                "kept_heads_all_boards": 1.0 - removed(fresh, g, full & heads),
                "kept_lane_total": float(g.volume_ul.sum()) / float(fresh.volume_ul.sum()),
            }
        )
    boards = np.nonzero(mask.any(axis=0))[0]
    return {
        "pickup_fraction": p,
        "model": model.model_dump(),
        "shots_kegel": n_kegel,
        "shots_heads": n_heads,
        "area_of_play_cells": int(mask.sum()),
        "area_of_play_boards": [int(boards.min()) + 1, int(boards.max()) + 1],
        "area_of_play_mean_width_boards": float(mask.sum(axis=1)[mask.any(axis=1)].mean()),
        "removed_check": frac(p),
        "pickup_if": sens,
        "curve": curve,
        "imbalance_ul": imbalance,
    }


def curve(
    fresh: OilGrid, shots: list[Track], model: TransferModel, width_m: float
) -> list[dict[str, Any]]:
    """Removed (area of play of the first 4.5 games) and heads kept after some games."""
    mask = area_of_play(fresh, shots[: round(KEGEL_GAMES * DELIVERIES_PER_GAME)], model, width_m)
    heads = mask & (fresh.x_edges_ft[:-1] < HEADS_FT)[:, None]
    _, after, _ = wear(fresh, shots, model, width_m)
    out = []
    for games in (4.5, 13.5):
        g = after[round(games * DELIVERIES_PER_GAME) - 1]
        out.append({"games": games, "removed_area_of_play": removed(fresh, g, mask),
                    "kept_heads_area_of_play": 1.0 - removed(fresh, g, heads)})  # fmt: skip
    return out


def feedback(
    scene: BowlerScene, fresh: OilGrid, releases: list[Any], model: TransferModel,
    mapping: OilFrictionMapping, width_m: float, tracks: list[Track], mask: Any,
) -> dict[str, Any]:  # fmt: skip
    """The calibration's shots re-simulated each on the lane as it is before it."""
    grid, load, own = fresh, 0.0, []
    for rel in releases:
        t = simulate(scene, _lane(scene, _ball_friction(scene, grid, mapping, width_m)), rel)
        own.append(t)
        grid, load, _ = apply_track(
            grid, t.x_m, t.y_m, lane_width_m=width_m, model=model, ball_load_ul=load
        )
        load, _ = absorb_between_shots(load, model)
    fixed, _, _ = wear(fresh, tracks[: len(releases)], model, width_m)
    own_mask = area_of_play(fresh, own, model, width_m)
    return {
        "removed_fixed_tracks": removed(fresh, fixed, mask),
        "removed_with_feedback": removed(fresh, grid, mask),
        "removed_with_feedback_own_area": removed(fresh, grid, own_mask),
        "breakpoint_board_shift": float(
            np.mean([t.breakpoint_board for t in own[-17:]])
            - np.mean([t.breakpoint_board for t in own[:17]])
        ),
        "entry_board_shift": float(
            np.nanmean([t.entry_board for t in own[-17:]])
            - np.nanmean([t.entry_board for t in own[:17]])
        ),
    }


def _ball_friction(
    scene: BowlerScene, grid: OilGrid, mapping: OilFrictionMapping, width_m: float
) -> GridFriction:
    return grid_friction(
        grid,
        lane_width_m=width_m,
        length_m=scene.lane.length_m,
        coverstock=scene.ball.coverstock,
        surface=scene.ball.surface,
        mapping=mapping,
    )


def _quantised(f: GridFriction, levels: int, mapping: OilFrictionMapping, scene: Any) -> Any:
    dry, oil = mapping.levels(scene.ball.coverstock, scene.ball.surface)
    mu = np.asarray(f.mu)
    q = oil + np.round((mu - oil) / (dry - oil) * (levels - 1)) / (levels - 1) * (dry - oil)
    g = simplify_grid(f.x_edges_m, f.y_edges_m, q)
    return f.model_copy(
        update={"x_edges_m": g.x_edges_m.tolist(), "y_edges_m": g.y_edges_m.tolist(),
                "mu": g.mu.tolist()}
    )  # fmt: skip


def _time(plan: Any) -> float:
    fn, args = kernel_call(plan)
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best


def resolution_cost(
    scene: BowlerScene, fresh: OilGrid, worn: OilGrid, releases: list[Any], width_m: float
) -> list[dict[str, Any]]:
    mapping = session_mapping(fresh, width_m)
    variants: list[tuple[str, GridFriction]] = []
    fresh_f = _ball_friction(scene, fresh, mapping, width_m)
    variants.append(("fresh pattern", fresh_f))
    one = None
    for cf, cb in CELLS:
        cells = session_oil_grid(preset(PATTERN), cell_ft=cf, cell_boards=cb)
        g = resample_grid(worn, cells.x_edges_ft, cells.board_edges)
        f = _ball_friction(scene, g, mapping, width_m)
        variants.append((f"worn, {cf:g} ft x {cb:g} board", f))
        if (cf, cb) == (1.0, 1.0):
            one = f
    assert one is not None
    for levels in (9, 5, 3):
        variants.append((f"worn, 1 ft x 1 board, mu in {levels} levels",
                         _quantised(one, levels, mapping, scene)))  # fmt: skip
    rows, ref = [], None
    for name, f in variants:
        lane = _lane(scene, f)
        shot = Shot(scene, lane=lane)
        t_sum, t_rec, tracks = [], [], []
        for rel in releases:
            plan = shot.plan(rel.to_physical(scene.lane), summary_only=False)
            rec = replace(plan, record_mode=RECORD_RATE, record_dt_s=RECORD_DT_S)
            t_sum.append(_time(replace(plan, record_mode=RECORD_SUMMARY)))
            t_rec.append(_time(rec))
            tracks.append(simulate(scene, lane, rel))
        entry = np.array([t.entry_board for t in tracks])
        bp_b = np.array([t.breakpoint_board for t in tracks])
        bp_ft = np.array([t.breakpoint_ft for t in tracks])
        if ref is None and name.startswith("worn"):
            ref = (entry, bp_b, bp_ft)
        row = {
            "grid": name,
            "x_lines": len(f.x_edges_m),
            "y_lines": len(f.y_edges_m),
            "kernel_summary_us": 1e6 * statistics.median(t_sum),
            "kernel_recorded_us": 1e6 * statistics.median(t_rec),
            "zone_events": statistics.mean(t.zone_events for t in tracks),
            "rhs": statistics.mean(t.n_rhs for t in tracks),
            "phase_changes": statistics.mean(t.phase_changes for t in tracks),
            "entry": entry,
            "bp_b": bp_b,
            "bp_ft": bp_ft,
            "mean_entry_board": float(np.nanmean(entry)),
            "mean_breakpoint_board": float(np.mean(bp_b)),
            "mean_breakpoint_ft": float(np.mean(bp_ft)),
        }
        rows.append(row)
    assert ref is not None
    for row in rows:
        de = np.abs(row.pop("entry") - ref[0])
        db = np.abs(row.pop("bp_b") - ref[1])
        dft = np.abs(row.pop("bp_ft") - ref[2])
        row["entry_board_diff_max"] = float(np.nanmax(de))
        row["entry_board_diff_mean"] = float(np.nanmean(de))
        row["breakpoint_board_diff_max"] = float(np.max(db))
        row["breakpoint_ft_diff_max"] = float(np.max(dft))
    return rows


def session_overhead(
    scene: BowlerScene, tracks: list[Track], model: TransferModel, width_m: float
) -> list[dict[str, Any]]:
    """Per shot of a session, besides the kernel: apply_track, and building the friction map,
    the lane and the Shot (ms), and the bytes of one stored grid (float64), per cell size."""
    out = []
    for cf, cb in CELLS:
        g = session_oil_grid(preset(PATTERN), cell_ft=cf, cell_boards=cb)
        mapping = session_mapping(g, width_m)
        t0 = time.perf_counter()
        for t in tracks:
            g, _, _ = apply_track(
                g, t.x_m, t.y_m, lane_width_m=width_m, model=model, ball_load_ul=0.0
            )
        t1 = time.perf_counter()
        for _ in range(10):
            Shot(scene, lane=_lane(scene, _ball_friction(scene, g, mapping, width_m)))
        t2 = time.perf_counter()
        out.append(
            {
                "cells": f"{cf:g} ft x {cb:g} board",
                "apply_track_ms": 1e3 * (t1 - t0) / len(tracks),
                "friction_lane_shot_ms": 1e3 * (t2 - t1) / 10,
                "grid_bytes": int(g.volume_ul.nbytes),
            }
        )
    return out


def _markdown(d: dict[str, Any]) -> str:
    c = d["calibration"]
    m = c["model"]
    lines = [
        "# Oil transfer: calibration and the oil grid's resolution cost",
        "",
        f"`python -m benchmarks.oil_grid --tracks {d['n_tracks']} --seed {d['seed']}` on "
        f"{d['machine']['nproc']} cores ({d['machine']['cpu']}, Python "
        f"{d['machine']['python']}); load average before {d['loadavg_before']}, after "
        f"{d['loadavg_after']}; {d['seconds']:.0f} s.",
        "",
        "## Calibration",
        "",
        f"Tracks: {d['n_tracks']} repeats of the house-shot example ({PATTERN}, a tweener "
        "breaking on board 5 at 40 ft) with the `pro` release scatter, recorded every 5 ms; "
        f"{c['shots_kegel']} shots = {KEGEL_GAMES} games x {DELIVERIES_PER_GAME} deliveries. "
        f"Area of play: {c['area_of_play_cells']} cells of 1 ft x 1 board, boards "
        f"{c['area_of_play_boards'][0]}-{c['area_of_play_boards'][1]}, "
        f"{c['area_of_play_mean_width_boards']:.1f} boards wide on average per row.",
        "",
        "| parameter | value | |",
        "|---|---|---|",
        f"| pickup_fraction | **{m['pickup_fraction']:.4f}** | fitted: 40 % removed from the "
        f"area of play after {KEGEL_GAMES} games (check: {100 * c['removed_check']:.2f} %) |",
        f"| carrydown_fraction | {m['carrydown_fraction']:g} per ft | assumed |",
        f"| absorption_fraction | {m['absorption_fraction']:g} | assumed |",
        f"| track_width_m | {m['track_width_m']:g} | argued (Hertz contact) |",
        "",
        "pickup_fraction fitted with another carrydown_fraction: "
        + ", ".join(f"{k}: {v:.4f}" for k, v in c["pickup_if"].items())
        + ".",
        "",
        "| games | removed, area of play | heads (< 15 ft) kept, area of play | heads kept, "
        "all boards | lane total kept |",
        "|---|---|---|---|---|",
    ]
    for r in c["curve"]:
        lines.append(
            f"| {r['games']:g} | {100 * r['removed_area_of_play']:.1f} % | "
            f"{100 * r['kept_heads_area_of_play']:.1f} % | {100 * r['kept_heads_all_boards']:.1f} "
            f"% | {100 * r['kept_lane_total']:.1f} % |"
        )
    fb = d["feedback"]
    lines += [
        "",
        f"Oil unaccounted for over {c['shots_heads']} shots: {c['imbalance_ul']:.2e} µL.",
        "",
        f"Feedback of the wear on the tracks ({c['shots_kegel']} shots re-simulated each on the "
        f"lane before it, power ramp): removed {100 * fb['removed_with_feedback']:.1f} % against "
        f"{100 * fb['removed_fixed_tracks']:.1f} % with the fresh lane's tracks; "
        f"{100 * fb['removed_with_feedback_own_area']:.1f} % from the area of play of the "
        "re-simulated shots themselves. The last game's shots break "
        f"{fb['breakpoint_board_shift']:+.2f} boards and enter {fb['entry_board_shift']:+.2f} "
        "boards from the first game's (same releases: no bowler adjusts).",
        "",
        "League scatter at the calibrated model (the area of play from its own shots): "
        + ", ".join(
            f"{r['games']:g} games: removed {100 * r['removed_area_of_play']:.0f} %, heads kept "
            f"{100 * r['kept_heads_area_of_play']:.0f} %"
            for r in d["league_curve"]
        )
        + ".",
        "",
        "## Resolution cost",
        "",
        f"{d['n_cost']} repeats of the shot on the lane after {d['worn_shots']} shots (worn on "
        f"the {REFERENCE_CELL[0]:g} ft x {REFERENCE_CELL[1]:g} board grid, coarsened with the "
        "volume conserved), session mapping (the calibrated mapping: power ramp 0.4 below "
        f"{d['reference_film_um']:.3f} µm). Kernel time: median per delivery of the best of 3. "
        f"Differences: against the worn {REFERENCE_CELL[0]:g} ft x {REFERENCE_CELL[1]:g} board "
        "grid, in boards (entry at the head pin "
        "line, breakpoint = the path's closest approach to the right gutter) and ft.",
        "",
        "| friction grid | x / y lines | zone events | slide/roll changes | right-hand sides | "
        "kernel, summary (µs) | kernel, recorded (µs) | entry board diff mean / max | "
        "breakpoint board diff max | breakpoint ft diff max |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in d["resolution"]:
        lines.append(
            f"| {r['grid']} | {r['x_lines']} / {r['y_lines']} | {r['zone_events']:.1f} | "
            f"{r['phase_changes']:.1f} | {r['rhs']:.0f} | "
            f"{r['kernel_summary_us']:.0f} | {r['kernel_recorded_us']:.0f} | "
            f"{r['entry_board_diff_mean']:.3f} / {r['entry_board_diff_max']:.3f} | "
            f"{r['breakpoint_board_diff_max']:.3f} | {r['breakpoint_ft_diff_max']:.2f} |"
        )
    lines += [
        "",
        f"Entry board of the {d['n_tracks']} pro-scatter repeats on the fresh lane: standard "
        f"deviation {d['entry_board_std']:.2f} boards (breakpoint board "
        f"{d['breakpoint_board_std']:.2f}).",
        "",
        "Per shot of a session besides the kernel (mean over 40 shots; 10 builds):",
        "",
        "| cells | apply_track (ms) | friction map + lane + Shot (ms) | stored grid (bytes, "
        "float64) |",
        "|---|---|---|---|",
    ]
    for r in d["overhead"]:
        lines.append(
            f"| {r['cells']} | {r['apply_track_ms']:.2f} | {r['friction_lane_shot_ms']:.2f} | "
            f"{r['grid_bytes']:,} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tracks", type=int, default=300)
    ap.add_argument("--cost", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    load_before = [round(x, 2) for x in os.getloadavg()]
    scene = house_scene()
    width = scene.lane.width_m
    fresh = session_oil_grid(preset(PATTERN))
    mapping = session_mapping(fresh, width)
    fresh_lane = _lane(scene, _ball_friction(scene, fresh, mapping, width))
    releases = _releases(scene, fresh_lane, PRESETS["pro"], a.tracks, a.seed)
    tracks = [simulate(scene, fresh_lane, r) for r in releases]
    cal = calibrate(fresh, tracks, width)
    model = TransferModel.model_validate(cal["model"])
    n_kegel = cal["shots_kegel"]
    mask = area_of_play(fresh, tracks[:n_kegel], model, width)
    fb = feedback(scene, fresh, releases[:n_kegel], model, mapping, width, tracks, mask)
    league = [
        simulate(scene, fresh_lane, r)
        for r in _releases(scene, fresh_lane, PRESETS["league"], cal["shots_heads"], a.seed + 1)
    ]
    league_curve = curve(fresh, league, model, width)
    worn_shots = 40
    fine = session_oil_grid(
        preset(PATTERN), cell_ft=REFERENCE_CELL[0], cell_boards=REFERENCE_CELL[1]
    )
    worn, _, _ = wear(fine, tracks[:worn_shots], model, width)
    cost = resolution_cost(scene, fresh, worn, releases[-a.cost :], width)
    overhead = session_overhead(scene, tracks[:worn_shots], model, width)
    import bowlrec

    d = {
        "n_tracks": a.tracks,
        "n_cost": a.cost,
        "seed": a.seed,
        "worn_shots": worn_shots,
        "reference_film_um": mapping.oiled_at_or_above_um,
        "machine": {
            "platform": platform.platform(),
            "cpu": platform.processor() or platform.machine(),
            "nproc": os.cpu_count(),
            "python": sys.version.split()[0],
            "bowlrec": bowlrec.__version__,
        },
        "loadavg_before": load_before,
        "calibration": cal,
        "feedback": fb,
        "league_curve": league_curve,
        "resolution": cost,
        "overhead": overhead,
        "entry_board_std": float(np.nanstd([t.entry_board for t in tracks], ddof=1)),
        "breakpoint_board_std": float(np.std([t.breakpoint_board for t in tracks], ddof=1)),
        "loadavg_after": [round(x, 2) for x in os.getloadavg()],
        "seconds": time.perf_counter() - t0,
    }
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "oil_grid.json").write_text(json.dumps(d, indent=2) + "\n", encoding="utf-8")
    (a.out / "oil_grid.md").write_text(_markdown(d), encoding="utf-8")
    print(_markdown(d))


if __name__ == "__main__":
    main()
