"""Ball-library commands: ``balls add|list|show|rm|export|import``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from bowlrec.archive import parse_ball_ref
from bowlrec.errors import SpecFileError

from ._app import app
from ._common import ArchiveOption, JsonOption, archive_errors, fail, print_table
from ._common import open_archive as _open

balls_app = typer.Typer(help="The archive's versioned ball-spec library.", no_args_is_help=True)
app.add_typer(balls_app, name="balls")


def _load_ball(path: Path) -> Any:
    """A ball from a file: a physical ball spec, a spec sheet in bowlers' units (it has
    ``weight_lb``), or the ``ball`` of a scene file (physical or bowler-language)."""
    from bowlrec.archive.ball_import import checked_ball
    from bowlrec.spec.loading import read_mapping

    if not path.exists():
        fail(f"{path}: no such file")
    try:
        data = read_mapping(path)
    except SpecFileError as err:
        raise SpecFileError(f"{path}: {err}") from None
    except OSError as err:
        fail(f"{path}: {err}")
    if isinstance(data, dict) and "ball" in data:  # one line per problem: file and field
        return checked_ball(f"{path}: ball", data["ball"] or {})
    return checked_ball(str(path), data or {}, joiner=": ")


@balls_app.command("add")
def add(
    name: Annotated[str, typer.Argument(help="Library name, e.g. 'house-pearl'.")],
    spec: Annotated[Path, typer.Argument(help="Ball spec file, or a scene file (its ball).")],
    note: Annotated[str, typer.Option(help="Free-text note stored with this version.")] = "",
    archive: ArchiveOption = None,
) -> None:
    """Add a ball spec; a changed spec under the same name becomes a new version."""
    store = _open(archive)
    with archive_errors():
        entry, created = store.balls.add(name, _load_ball(spec), note=note)
    typer.echo(f"{entry.ref} {'added' if created else 'unchanged (identical to the latest)'}")


@balls_app.command("list")
def list_balls(
    all_versions: Annotated[
        bool, typer.Option("--all", help="Every version, not only the latest.")
    ] = False,
    archive: ArchiveOption = None,
    as_json: JsonOption = False,
) -> None:
    """List the library (latest version of each name unless --all)."""
    store = _open(archive)
    entries = store.balls.list(all_versions=all_versions)
    if as_json:
        typer.echo(json.dumps([e.to_json_dict() for e in entries], indent=2))
        return
    from rich.table import Table

    from bowlrec.bowling.ball import BowlerBall

    table = Table(title=f"{len(entries)} ball(s) in {store.root}")
    for column in ("ball", "kind", "mass", "RG", "added", "note"):
        table.add_column(column, overflow="fold")
    for e in entries:
        b = e.ball
        if isinstance(b, BowlerBall):
            kind, mass = "spec sheet", f"{b.weight_lb:g} lb"
            rg = f"{b.rg_in:.3f} in, diff {b.differential_in:.3f}"
        else:
            kind, mass = "physical", f"{b.mass_kg:g} kg"
            rg = " ".join(f"{v:.4f}" for v in b.rg_m) + " m"
        table.add_row(e.ref, kind, mass, rg, e.added_at, e.note)
    print_table(table)


@balls_app.command("show")
def show(
    ref: Annotated[str, typer.Argument(help="NAME (latest) or NAME@VERSION.")],
    archive: ArchiveOption = None,
) -> None:
    """Print one ball spec as JSON."""
    store = _open(archive)
    with archive_errors():
        entry = store.balls.get(ref)
    if hasattr(entry.ball, "spec_sheet"):
        typer.echo(entry.ball.spec_sheet())
    typer.echo(json.dumps(entry.to_json_dict(), indent=2))


@balls_app.command("rm")
def remove(
    ref: Annotated[str, typer.Argument(help="NAME@VERSION to remove.")],
    archive: ArchiveOption = None,
) -> None:
    """Remove one version (runs that used it keep their own copy of the spec)."""

    store = _open(archive)
    with archive_errors():
        name, version = parse_ball_ref(ref)
        if version is None:
            fail(f"{ref!r}: give the version to remove, e.g. {name}@1")
        store.balls.remove(name, version)
    typer.echo(f"removed {ref}")


@balls_app.command("export")
def export(
    out: Annotated[Path, typer.Argument(help="JSON file to write (every version).")],
    archive: ArchiveOption = None,
) -> None:
    """Export the whole library (all versions) to JSON."""
    store = _open(archive)
    doc = store.balls.export_json(out)
    typer.echo(f"{out}: {len(doc['balls'])} ball version(s)")


@balls_app.command("import")
def import_(
    source: Annotated[Path, typer.Argument(help="JSON file written by 'balls export'.")],
    archive: ArchiveOption = None,
) -> None:
    """Import an exported library; specs already present are skipped."""
    store = _open(archive)
    if not source.exists():
        fail(f"{source}: no such file")
    with archive_errors():
        results = store.balls.import_json(source)
    for entry, created in results:
        typer.echo(f"{entry.ref} {'added' if created else 'already present'}")


@balls_app.command("add-examples")
def add_examples(archive: ArchiveOption = None) -> None:
    """Add the curated ball catalog (spec sheets a pro shop would recognize, each with its
    sources) to the archive's ball library, named by their ids; the note is the first source."""
    from bowlrec.bowling.catalog import citation
    from bowlrec.bowling.layout import load_example_library

    store = _open(archive)
    for item in load_example_library().balls:
        entry, created = store.balls.add(item.id, item.ball, note=citation(item.sources[0]))
        typer.echo(f"{entry.ref} {'added' if created else 'unchanged'}")
