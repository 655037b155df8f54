"""Bowlers'-language commands: ``patterns`` (oil presets and their statistics), ``sheet`` (ball
spec sheets of the curated catalog, with USBC legality and sources), ``bowler-scene`` (a template
file)."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import typer

from ._app import app
from ._common import JsonOption, fail, print_table


@app.command()
def patterns(
    name: Annotated[str | None, typer.Argument(help="Preset name; omitted: list all.")] = None,
    as_json: JsonOption = False,
) -> None:
    """Oil-pattern presets with their Kegel-sheet statistics (volume, crosses, ratio)."""

    from bowlrec.bowling.oil import pattern_statistics, preset, preset_names, unknown_preset

    names = preset_names() if name is None else [name]
    if name is not None and name not in preset_names():
        fail(unknown_preset("pattern", name))
    rows = []
    for n in names:
        p = preset(n)
        stats = asdict(pattern_statistics(p))
        kind = "kegel sheet" if p.kind == "kegel" else "rectangles"
        kind += ", approximation" if p.approximation else ""
        rows.append({"name": n, "kind": kind, "source": p.source, **stats})
    if as_json or name is not None:
        typer.echo(json.dumps(rows if name is None else rows[0], indent=2))
        return
    from rich.table import Table

    table = Table(title="oil pattern presets (bowlrec patterns NAME: one, with its source)")
    for col in ("name", "length (ft)", "oil ends (ft)", "volume (mL)", "ratio", "crosses", "kind"):
        table.add_column(col)
    for r in rows:
        ratio = "-" if r["ratio"] is None else f"{r['ratio']:.2f}:1"
        crosses = "-" if r["total_crosses"] is None else str(r["total_crosses"])
        table.add_row(
            r["name"],
            f"{r['distance_ft']:g}",
            f"{r['oil_end_ft']:g}",
            f"{r['total_ml']:.2f}",
            ratio,
            crosses,
            r["kind"],
        )
    print_table(table)


@app.command()
def sheet(
    ball: Annotated[
        str | None, typer.Argument(help="Ball id in the curated catalog; omitted: list ids.")
    ] = None,
) -> None:
    """A ball of the curated catalog as a spec sheet, with its USBC legality and its sources."""
    from bowlrec.bowling.catalog import citation
    from bowlrec.bowling.layout import load_example_library
    from bowlrec.bowling.legality import RULE_SETS, check_legality

    lib = load_example_library()
    if ball is None:
        for entry in lib.balls:
            year = "-" if entry.year is None else str(entry.year)
            kind = " (illustrative)" if entry.illustrative else ""
            b = entry.ball
            typer.echo(
                f"{entry.id:34s} {year:>4s}  {b.brand:14s} {b.name}, {b.weight_lb:g} lb{kind}"
            )
        return
    entries = {e.id: e for e in lib.balls}
    if ball not in entries:
        from bowlrec.suggest import did_you_mean, some_names

        hint = did_you_mean(ball, entries) or f"ids: {some_names(entries)}"
        fail(f"no ball {ball!r} in the curated catalog; {hint} (`bowlrec sheet` lists them all)")
    entry = entries[ball]
    typer.echo(entry.ball.spec_sheet())
    typer.echo(f"  Year            {'not found' if entry.year is None else entry.year}")
    typer.echo(f"    ({entry.year_note})")
    for rules in RULE_SETS:
        typer.echo(str(check_legality(entry.ball, rules)))
    typer.echo("sources:")
    for source in entry.sources:
        typer.echo(f"  - {citation(source)}")
        if source.quote:
            typer.echo(f'    "{source.quote}"')
    if entry.second_hand is not None:
        where = {"review": "reviews", "database": "third-party spec databases"}
        typer.echo(
            f"  specs as printed in {where[entry.second_hand]}: the maker's own spec sheet was "
            "not read"
        )
    if entry.assumed:
        typer.echo(f"assumed (not stated by the sources): {', '.join(entry.assumed)}")
    if entry.note:
        typer.echo(f"note: {entry.note}")


@app.command("bowler-scene")
def bowler_scene(
    out: Annotated[
        Path, typer.Argument(help="File to write: .json, or .yaml/.yml for YAML.")
    ] = Path("bowler.json"),
    force: Annotated[
        bool, typer.Option("--force", "-f", help="Replace the file if it exists.")
    ] = False,
) -> None:
    """Write a complete bowler-language scene with every field at its default, to edit.

    An existing file is kept (an edited scene is not lost) unless --force is given.
    """
    from bowlrec.atomic_files import atomic_path
    from bowlrec.bowling.scene import BowlerScene

    suffix = out.suffix.lower()
    if suffix not in (".json", ".yaml", ".yml"):
        fail(f"{out}: a scene file's name ends in .json, .yaml or .yml")
    if out.exists() and not force:
        fail(f"{out} exists: keeping it (--force replaces it)")
    doc = BowlerScene().model_dump(mode="json")
    if suffix == ".json":
        text = json.dumps(doc, indent=2) + "\n"
    else:
        import yaml

        text = yaml.safe_dump(doc, sort_keys=False)
    try:
        with atomic_path(out, durable=False) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as err:
        fail(f"{out}: {err.strerror or err}", code=1)
    typer.echo(f"{out}: simulate it with: bowlrec simulate {out}")
