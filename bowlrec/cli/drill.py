"""Drillers' commands: ``drill`` (a drilled ball's RG, differentials, static weights and USBC
legality from its holes) and ``layout convert`` (2LS, Dual Angle and VLS into each other)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ._app import app
from ._common import JsonOption, fail, validated_options

if TYPE_CHECKING:
    from bowlrec.bowling.drilling import DrilledBall, DrillingSpec
    from bowlrec.bowling.layout import PAP

layout_app = typer.Typer(help="Drilling layouts: 2LS, Dual Angle and VLS.", no_args_is_help=True)
app.add_typer(layout_app, name="layout")

_SYSTEMS = ("dual_angle", "vls", "2ls")


def _one_line(err: Exception) -> str:
    """A validation error's lines joined into one."""
    from pydantic import ValidationError

    if isinstance(err, ValidationError):
        from bowlrec.spec import format_validation_error

        return "; ".join(format_validation_error(err).splitlines())
    return str(err)


def _example_spec() -> DrillingSpec:
    from bowlrec.bowling.ball import BowlerBall, CenterOfMassMark
    from bowlrec.bowling.drilling import DrillingSpec, GripDrilling, HoleSpec
    from bowlrec.bowling.layout import PAP, DualAngle

    finger = HoleSpec(diameter_in=0.875, depth_in=2.5)
    return DrillingSpec(
        ball=BowlerBall(
            name="example 15 lb symmetric",
            weight_lb=15.0,
            rg_in=2.50,
            differential_in=0.050,
            coverstock="reactive_pearl",
        ),
        layout=DualAngle(drilling_angle_deg=45.0, pin_to_pap_in=4.5, val_angle_deg=30.0),
        pap=PAP(over_in=5.0, up_in=0.5),
        grip=GripDrilling(
            middle=finger,
            ring=finger,
            thumb=HoleSpec(diameter_in=1.0, depth_in=2.75),
            bridge_in=0.25,
            middle_span_in=4.0,
            ring_span_in=4.0,
        ),
        undrilled_cg=CenterOfMassMark(over_in=0.0, up_in=0.0, static_oz=3.0),
    )


def _load_spec(path: Path) -> DrillingSpec:
    from bowlrec.bowling.drilling import DrillingSpec

    if not path.exists():
        fail(f"{path}: no such file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return DrillingSpec.model_validate(data)
    except (ValueError, UnicodeDecodeError) as err:
        fail(f"{path}: invalid drilling spec: {_one_line(err)}")


def _weights(w: Any) -> dict[str, float]:
    return {"top_oz": w.top_oz, "side_oz": w.side_oz, "finger_oz": w.finger_oz}


def _report(spec: DrillingSpec, d: DrilledBall) -> dict[str, Any]:
    r, hand = spec.ball.radius_in, spec.pap.handedness
    measured = spec.measured_static_weights
    legality = d.legality(spec.rules, measured)
    lo, mid, hi = d.rg_in
    return {
        "ball": spec.ball.name,
        "symmetric": spec.ball.core_type == "symmetric",
        "undrilled_weight_lb": d.undrilled_mass_kg / 0.45359237,
        "weight_lb": d.weight_lb,
        "removed_oz": d.removed_oz,
        "shell_density_g_cm3": d.shell_density_g_cm3,
        "rg_in": {"min": lo, "int": mid, "max": hi},
        "differential_in": d.differential_in,
        "intermediate_differential_in": d.intermediate_differential_in,
        "undrilled": {
            "rg_in": spec.ball.rg_in,
            "differential_in": spec.ball.differential_in,
            "intermediate_differential_in": spec.ball.intermediate_differential_in,
            "static_weights_oz": _weights(d.undrilled_weights),
        },
        "static_weights_oz": {
            "computed": _weights(d.computed_weights),
            "measured": None if measured is None else _weights(measured),
            "used": "measured" if measured is not None else "computed",
        },
        "com_offset_grip_mm": [float(c) * 1000.0 for c in d.com_offset_m],
        "pin": _axis(d, "pin"),
        "psa": _axis(d, "psa"),
        "holes": [
            {
                "name": p.name,
                "purpose": p.purpose,
                "over_in": p.coords(r, hand)[0],
                "up_in": p.coords(r, hand)[1],
                "diameter_in": p.spec.diameter_in,
                "depth_in": p.spec.depth_in,
                "removed_oz": m.mass_oz,
            }
            for p, m in zip(d.placed, d.holes, strict=True)
        ],
        "legality": {
            "rule_set": legality.rule_set,
            "legal": legality.is_legal,
            "violations": [str(v) for v in legality.violations],
        },
    }


def _axis(d: DrilledBall, which: Any) -> dict[str, float]:
    over, up = d.axis_position_in(which)
    return {"moved_in": d.axis_moved_in(which), "over_in": over, "up_in": up}


def _print_report(rep: dict[str, Any]) -> None:
    rg, und = rep["rg_in"], rep["undrilled"]
    w = rep["static_weights_oz"]
    used = w[w["used"]]
    lines = [
        f"{rep['ball']}: drilled {rep['weight_lb']:.3f} lb ({rep['removed_oz']:.2f} oz removed "
        f"at {rep['shell_density_g_cm3']:.3f} g/cm^3)",
        f"  RG        {rg['min']:.4f} in (undrilled {und['rg_in']:.4f}); int {rg['int']:.4f}, "
        f"max {rg['max']:.4f}",
        f"  Diff      {rep['differential_in']:.4f} in (undrilled {und['differential_in']:.4f})",
        f"  Int diff  {rep['intermediate_differential_in']:.4f} in (undrilled "
        f"{und['intermediate_differential_in']:.4f})",
        f"  Static    top {used['top_oz']:+.2f} oz, side {used['side_oz']:+.2f} oz, finger "
        f"{used['finger_oz']:+.2f} oz ({w['used']})",
    ]
    if w["used"] == "measured":
        c = w["computed"]
        lines.append(
            f"            computed: top {c['top_oz']:+.2f}, side {c['side_oz']:+.2f}, finger "
            f"{c['finger_oz']:+.2f} oz (measured weights win)"
        )
    for name in ("pin", "psa"):
        a = rep[name]
        where = f"now {a['over_in']:+.3f} over x {a['up_in']:+.3f} up"
        if name == "psa" and rep["symmetric"]:
            # a symmetric ball has no PSA before drilling: the holes alone place the new one
            lines.append(f"  {name.upper():<9} {where} (set by the holes: the ball had none)")
        else:
            lines.append(f"  {name.upper():<9} moved {a['moved_in']:.3f} in, {where}")
    for h in rep["holes"]:
        lines.append(
            f"  hole {h['name']:<8} {h['diameter_in']:.3f} x {h['depth_in']:.3f} in at "
            f"{h['over_in']:+.3f} over x {h['up_in']:+.3f} up: {h['removed_oz']:.2f} oz"
        )
    leg = rep["legality"]
    lines.append(f"  USBC ({leg['rule_set']}): " + ("legal" if leg["legal"] else "ILLEGAL"))
    lines += [f"    - {v}" for v in leg["violations"]]
    typer.echo("\n".join(lines))


@app.command()
def drill(
    spec: Annotated[
        Path | None,
        typer.Argument(
            help="Drilling spec (.json: ball, layout, pap, grip, ...); omitted: --example."
        ),
    ] = None,
    example: Annotated[
        bool, typer.Option("--example", help="Print an example drilling spec (JSON) to edit.")
    ] = False,
    as_json: JsonOption = False,
) -> None:
    """The drilled ball's weight, RG, differential, intermediate differential, static weights
    and USBC legality, from its holes (measured static weights in the spec win)."""
    if example or spec is None:
        typer.echo(json.dumps(_example_spec().model_dump(mode="json"), indent=2))
        return
    loaded = _load_spec(spec)
    try:
        drilled = loaded.drill()
    except ValueError as err:
        fail(f"{spec}: {_one_line(err)}")
    rep = _report(loaded, drilled)
    if as_json:
        typer.echo(json.dumps(rep, indent=2))
        return
    _print_report(rep)


def _layout(system: str, a: float, b: float, c: float, flag: bool) -> Any:
    from bowlrec.bowling.layout import VLS, DualAngle, TwoLS

    if system == "dual_angle":
        return DualAngle(drilling_angle_deg=a, pin_to_pap_in=b, val_angle_deg=c)
    if system == "vls":
        return VLS(pin_to_pap_in=a, psa_to_pap_in=b, pin_buffer_in=c, pin_above_pap=not flag)
    return TwoLS(
        pin_to_pap_in=a, psa_to_pap_in=b, pin_to_grip_center_in=c, pin_toward_fingers=not flag
    )


def _numbers(layout: Any) -> dict[str, Any]:
    return layout.model_dump(mode="json")


def _text(layout: Any) -> str:
    if layout.system == "dual_angle":
        return (
            f"Dual Angle  {layout.drilling_angle_deg:.1f} deg x {layout.pin_to_pap_in:.3f} in x "
            f"{layout.val_angle_deg:.1f} deg"
        )
    if layout.system == "vls":
        side = "above" if layout.pin_above_pap else "below"
        return (
            f"VLS         {layout.pin_to_pap_in:.3f} x {layout.psa_to_pap_in:.3f} x "
            f"{layout.pin_buffer_in:.3f} in (pin {side} the PAP)"
        )
    side = "finger" if layout.pin_toward_fingers else "thumb"
    return (
        f"2LS         {layout.pin_to_pap_in:.3f} x {layout.psa_to_pap_in:.3f} x "
        f"{layout.pin_to_grip_center_in:.3f} in (pin on the {side} side)"
    )


@layout_app.command("convert")
def layout_convert(
    system: Annotated[str, typer.Argument(help="Source system: dual_angle, vls or 2ls.")],
    first: Annotated[float, typer.Argument(help="Drilling angle (deg) or pin-to-PAP (in).")],
    second: Annotated[float, typer.Argument(help="Pin-to-PAP (DA) or PSA-to-PAP (in).")],
    third: Annotated[
        float, typer.Argument(help="VAL angle (deg), pin buffer or pin-to-grip (in).")
    ],
    pap_over: Annotated[float, typer.Option("--pap-over", help="PAP over (in).")] = 5.0,
    pap_up: Annotated[float, typer.Option("--pap-up", help="PAP up (+) / down (-) (in).")] = 0.5,
    left: Annotated[bool, typer.Option("--left", help="Left-handed bowler.")] = False,
    other_side: Annotated[
        bool,
        typer.Option(
            "--other-side",
            help="VLS: pin below the PAP; 2LS: pin on the thumb side of the PAP-grip line.",
        ),
    ] = False,
    to: Annotated[
        str | None, typer.Option("--to", help="Target system; omitted: all three.")
    ] = None,
    diameter_in: Annotated[float, typer.Option("--diameter", help="Ball diameter (in).")] = 8.595,
    as_json: JsonOption = False,
) -> None:
    """A layout in 2LS, Dual Angle and VLS for the bowler's PAP (2LS depends on it)."""
    from bowlrec.bowling.layout import PAP, convert_layout

    for name, value in (("system", system), ("--to", to)):
        if value is not None and value not in _SYSTEMS:
            fail(f"{name} = {value!r} must be one of {', '.join(_SYSTEMS)}")
    if not 0.0 < diameter_in <= 78.0:
        fail(f"--diameter = {diameter_in!r} must be in (0, 78] in")
    pap: PAP = validated_options(
        PAP,
        {"over_in": pap_over, "up_in": pap_up, "handedness": "left" if left else "right"},
        {"over_in": "--pap-over", "up_in": "--pap-up"},
    )
    try:
        source = _layout(system, first, second, third, other_side)
        targets = [to] if to else list(_SYSTEMS)
        out = [convert_layout(source, t, pap, 0.5 * diameter_in) for t in targets]  # type: ignore[arg-type]
    except ValueError as err:
        fail(_one_line(err))
    if as_json:
        rows: dict[str, Any] = {str(o.system): _numbers(o) for o in out}
        typer.echo(json.dumps(rows if to is None else rows[to], indent=2))
        return
    typer.echo("\n".join(_text(o) for o in out))
