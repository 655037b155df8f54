"""The Magnus lift's spin parameter S along real deliveries, against the range of the lift
model's data (``docs/lane-and-air.md``).

    python -m benchmarks.magnus_spin

Deliveries: the two bowler example scenes (``examples/bowler``) as written, and a grid of
bowler deliveries at 15, 17.5 and 20 mph and 250, 400 and 550 rpm with the ball, layout, axis
(50 deg rotation, 12 deg tilt), laydown and pattern of ``examples/bowler/pocket-right.json``,
each aimed into the pocket (board 17.5, 4-6 deg) by :func:`bowlrec.bowling.aim.aim` varying
target and laydown (where no shot enters the pocket, the closest one tried). Every delivery is
simulated with Magnus lift on (``sawicki2003``), so S is the one the lift sees, and once
without it, for the lift's entry shift.

Along each recorded path (the scene's own samples, which include the slide -> roll event):

* S = R |w x v| / |v|^2 = R |w_perp| / |v| (:func:`spin_parameter`, the kernel's definition in
  ``bowlrec.core.dynamics.external_accel``; v is the geometric center's velocity, horizontal),
  at release, at the start of rolling (the slide -> roll event), at the pins, and its minimum
  and maximum; while rolling the contact point is at rest, which makes
  S = sqrt(1 + (R w_z / |v|)^2) >= 1;
* the share of the time with S above 0.6, the end of the lift data's range;
* what the extrapolation above S = 0.6 is worth: the lift's horizontal component across the
  path, a(t), gives the bare double integral D = int_0^T (T - t) a(t) dt (the lateral
  displacement at the pins it would cause if nothing else responded); reported are the share of
  D from S > 0.6 and the ratio D_hold / D, with D_hold computed with C_L held at its value at
  S = 0.6 (0.45) above it instead of continued linearly. The ratio is an estimate of how much a
  coefficient that stops growing at the range's end would change the lift's deflection; D
  leaves out the friction's response (the table shows D next to the simulated entry shift);
* the entry shift of the lift in the simulation (y at the pins with lift minus without, boards,
  +: left).

Writes ``benchmarks/results/magnus_spin.json`` (every number) and ``magnus_spin.md`` (the
table). The output has no date or timing: it changes only when the physics or the scenes do.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
EXAMPLES = ("examples/bowler/house-shot-right.json", "examples/bowler/pocket-right.json")
GRID_BASE = "examples/bowler/pocket-right.json"
SPEEDS_MPH = (15.0, 17.5, 20.0)
REVS_RPM = (250.0, 400.0, 550.0)
BOARD_M = 41.5 * 0.0254 / 39.0
#: the lift data's range of S (Nathan 2008; docs/lane-and-air.md)
DATA_RANGE = (0.09, 0.6)


def spin_parameter(
    radius_m: float, velocity_mps: NDArray[np.float64], omega_radps: NDArray[np.float64]
) -> NDArray[np.float64]:
    """S = R |w x v| / |v|^2 per sample ((n, 3) arrays, v horizontal): R |w_perp| / |v|, with
    w_perp the part of w across v."""
    wxv = np.cross(omega_radps, velocity_mps)
    v2 = np.sum(velocity_mps * velocity_mps, axis=1)
    return np.asarray(radius_m * np.linalg.norm(wxv, axis=1) / v2)


def lift_coefficient(s: NDArray[np.float64]) -> NDArray[np.float64]:
    """C_L(S) of ``sawicki2003`` as the kernel evaluates it
    (:func:`bowlrec.core.dynamics.lift_coefficient_per_spin` times S)."""
    from bowlrec.core.codes import LIFT_SAWICKI
    from bowlrec.core.dynamics import lift_coefficient_per_spin

    return np.array([x * lift_coefficient_per_spin(float(x), LIFT_SAWICKI) for x in s])


def _bowler(rel: str) -> Any:
    from bowlrec.scene_input import parse_scene_file

    parsed = parse_scene_file(ROOT / rel)
    assert parsed.bowler is not None, rel
    return parsed.bowler


def deliveries() -> list[dict[str, Any]]:
    """name, bowler scene and how it was aimed, for every delivery of the benchmark."""
    from bowlrec.bowling.aim import aim

    out: list[dict[str, Any]] = [
        {"name": Path(rel).stem, "bowler": _bowler(rel), "aim": "as written"} for rel in EXAMPLES
    ]
    base = _bowler(GRID_BASE)
    for mph in SPEEDS_MPH:
        for rpm in REVS_RPM:
            d = base.delivery.model_copy(update={"speed_mph": mph, "rev_rate_rpm": rpm})
            scene = base.model_copy(update={"delivery": d})
            res = aim(scene, ("target", "laydown"))
            how = "target + laydown" + ("" if res.found else " (closest, not in the pocket)")
            out.append({"name": f"{mph:g} mph {rpm:g} rpm", "bowler": res.scene, "aim": how})
    return out


def measure(name: str, bowler: Any, how: str) -> dict[str, Any]:
    """S and the lift along one delivery (module docstring)."""
    from bowlrec.bowling.report import bowler_report
    from bowlrec.core.codes import LIFT_NONE, LIFT_SAWICKI
    from bowlrec.core.solver import solve

    plan = dataclasses.replace(bowler.to_scene().resolve(), lift_model=LIFT_SAWICKI)
    tr = solve(plan)
    tr_off = solve(dataclasses.replace(plan, lift_model=LIFT_NONE))
    off = tr_off.summary
    entry = bowler_report(tr_off, bowler.lane, bowler.delivery.handedness)
    r = plan.radius_m
    t, v, w = tr.t_s, tr.velocity_mps, tr.omega_radps
    s = spin_parameter(r, v, w)
    rolling = tr.phase == 1
    i_roll = int(np.argmax(rolling)) if rolling.any() else None
    # the lift's horizontal component across the path (m/s^2), as the kernel computes it
    k_l = 0.5 * plan.air_density_kg_m3 * math.pi * r * r / plan.mass_kg
    speed = np.linalg.norm(v, axis=1)
    wxv = np.cross(w, v)
    across = np.stack([-v[:, 1], v[:, 0], np.zeros(len(v))], axis=1) / speed[:, None]
    unit = np.sum(wxv * across, axis=1) / np.linalg.norm(wxv, axis=1)
    cl = lift_coefficient(s)
    hold = np.where(s > DATA_RANGE[1], lift_coefficient(np.array([DATA_RANGE[1]]))[0], cl)
    lever = t[-1] - t
    a = k_l * cl * speed**2 * unit
    a_hold = k_l * hold * speed**2 * unit
    above = s > DATA_RANGE[1]
    d_all = float(np.trapezoid(lever * a, t))
    d_above = float(np.trapezoid(lever * np.where(above, a, 0.0), t))
    d_hold = float(np.trapezoid(lever * a_hold, t))
    dt = np.diff(t)
    mid_above = 0.5 * (above[1:].astype(float) + above[:-1].astype(float))
    d = bowler.delivery
    sm = tr.summary
    return {
        "name": name,
        "aim": how,
        "speed_mph": d.speed_mph,
        "rev_rate_rpm": d.rev_rate_rpm,
        "axis_rotation_deg": d.axis_rotation_deg,
        "axis_tilt_deg": d.axis_tilt_deg,
        "outcome": sm.outcome,
        "entry_board_without_lift": entry.entry_board,
        "entry_angle_deg_without_lift": entry.entry_angle_deg,
        "samples": int(tr.n_samples),
        "s_release": float(s[0]),
        "s_roll_start": None if i_roll is None else float(s[i_roll]),
        "roll_start_ft": None if i_roll is None else float(tr.position_m[i_roll, 0] / 0.3048),
        "s_pins": float(s[-1]) if sm.outcome == "pins" else None,
        "s_min": float(s.min()),
        "s_max": float(s.max()),
        "s_min_rolling": float(s[rolling].min()) if rolling.any() else None,
        "s_max_sliding": float(s[~rolling].max()),
        "time_share_above_range": float(np.sum(dt * mid_above) / (t[-1] - t[0])),
        "cl_release": float(cl[0]),
        "lift_release_N": float(plan.mass_kg * k_l * cl[0] * speed[0] ** 2),
        "lift_release_across_N": float(plan.mass_kg * a[0]),
        "lift_pins_N": (
            float(plan.mass_kg * k_l * cl[-1] * speed[-1] ** 2) if sm.outcome == "pins" else None
        ),
        "lift_pins_across_N": float(plan.mass_kg * a[-1]) if sm.outcome == "pins" else None,
        "cl_max": float(cl.max()),
        "lateral_double_integral_m": d_all,
        "share_from_above_range": d_above / d_all,
        "held_over_linear": d_hold / d_all,
        "entry_shift_boards": (
            None
            if sm.y_end_m is None or off.y_end_m is None or sm.outcome != "pins"
            else (sm.y_end_m - off.y_end_m) / BOARD_M
        ),
    }


def _f(x: float | None, fmt: str = ".3f") -> str:
    return "-" if x is None else format(x, fmt)


def _entry(r: dict[str, Any]) -> str:
    b, a = r["entry_board_without_lift"], r["entry_angle_deg_without_lift"]
    return "-" if b is None or a is None else f"board {b:.1f}, {a:.1f} deg"


def write(doc: dict[str, Any]) -> None:
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "magnus_spin.json").write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    rows = doc["deliveries"]
    ex = [r for r in rows if r["aim"] == "as written"]
    grid = [r for r in rows if r["aim"] != "as written"]

    def rng(key: str, sel: list[dict[str, Any]], fmt: str = ".2f") -> str:
        vals = [r[key] for r in sel if r[key] is not None]
        return f"{min(vals):{fmt}}-{max(vals):{fmt}}"

    lines = [
        "# Magnus lift: the spin parameter S along real deliveries",
        "",
        "Written by `python -m benchmarks.magnus_spin` (see its docstring); the lift model and "
        "its uncertainty in docs/lane-and-air.md. bowlrec "
        f"{doc['bowlrec_version']}, physics {doc['physics_version']}.",
        "",
        f"S = R |w x v| / |v|^2 with Magnus lift on (`sawicki2003`). The lift data's range is "
        f"S {DATA_RANGE[0]}-{DATA_RANGE[1]}; above it the model continues C_L = 0.09 + 0.6 S "
        "(C_L(1.0) = 0.69).",
        "",
        f"- bowler examples: S at release {rng('s_release', ex)}, at the start of rolling "
        f"{rng('s_roll_start', ex)}, at the pins {rng('s_pins', ex)};",
        f"- the grid ({len(grid)} deliveries, 15-20 mph, 250-550 rpm): S at release "
        f"{rng('s_release', grid)}, at the start of rolling {rng('s_roll_start', grid)}, at the "
        f"pins {rng('s_pins', grid)}, over every path {min(r['s_min'] for r in rows):.2f}-"
        f"{max(r['s_max'] for r in rows):.2f};",
        f"- time above S = {DATA_RANGE[1]}: {rng('time_share_above_range', rows, '.0%')} of "
        "each path; "
        f"share of the lateral lift's double integral from S > {DATA_RANGE[1]}: "
        f"{rng('share_from_above_range', rows, '.0%')};",
        f"- the lift at release {rng('lift_release_N', rows)} N, "
        f"{rng('lift_release_across_N', rows, '+.2f')} N of it across the path; at the pins "
        f"{rng('lift_pins_N', rows)} N, {rng('lift_pins_across_N', rows, '+.2f')} N across (the "
        "rest is vertical: the forward roll's part of w x v, which presses the ball on the lane);",
        f"- C_L held at C_L({DATA_RANGE[1]}) = 0.45 above the range instead of continued: the "
        f"lateral double integral times {rng('held_over_linear', rows)}.",
        "",
        "| delivery | aim | entry without lift | S release | S at roll start (ft) | S at pins | "
        "S min | S max | time S > 0.6 | D (boards) | D from S > 0.6 | held / linear | "
        "entry shift by lift (boards) |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        roll = (
            "-"
            if r["s_roll_start"] is None
            else f"{r['s_roll_start']:.3f} ({r['roll_start_ft']:.1f})"
        )
        lines.append(
            f"| {r['name']} | {r['aim']} | {_entry(r)} | {r['s_release']:.3f} | {roll} | "
            f"{_f(r['s_pins'])} | {r['s_min']:.3f} | {r['s_max']:.3f} | "
            f"{r['time_share_above_range']:.0%} | "
            f"{r['lateral_double_integral_m'] / BOARD_M:+.2f} | "
            f"{r['share_from_above_range']:.0%} | {r['held_over_linear']:.2f} | "
            f"{_f(r['entry_shift_boards'], '+.2f')} |"
        )
    lines += [
        "",
        "Entry without lift: board and angle at the pins of the run without lift (the aim's "
        "shot). S at roll start: at the slide -> roll event (its x in ft); '-': the ball slides "
        "to the pins. Time S > 0.6: share of the time from release to the end. "
        "D = int (T - t) a(t) dt, a: the lift's horizontal component across the path (the "
        "lift's deflection at the pins "
        "without the friction's response, an estimate of the entry shift); D from S > 0.6: its "
        "share from the samples above the range. Held / linear: D with C_L held at 0.45 "
        "above S = 0.6, over D as the model computes it. Entry shift: y at the pins with the "
        "lift minus without (+: left).",
    ]
    (RESULTS / "magnus_spin.md").write_text("\n".join(lines) + "\n")


def main() -> int:
    import bowlrec
    from bowlrec import PHYSICS_VERSION

    rows = [measure(d["name"], d["bowler"], d["aim"]) for d in deliveries()]
    for r in rows:
        print(
            f"{r['name']:24s} S release {r['s_release']:.3f} roll {_f(r['s_roll_start'])} "
            f"pins {_f(r['s_pins'])} max {r['s_max']:.3f} held/linear "
            f"{r['held_over_linear']:.2f}",
            flush=True,
        )
    doc = {
        "generated_by": "python -m benchmarks.magnus_spin",
        "bowlrec_version": bowlrec.__version__,
        "physics_version": PHYSICS_VERSION,
        "data_range": list(DATA_RANGE),
        "deliveries": rows,
    }
    write(doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
