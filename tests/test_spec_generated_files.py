"""The committed examples/paper/*.json and schemas/*.json are what the code generates."""

from __future__ import annotations

from pathlib import Path

import pytest

from bowlrec.cli.schemas import SCHEMAS, export_schemas, schema_file
from bowlrec.paper import TABLE_III, paper_scene, write_paper_examples
from bowlrec.scene_input import parse_scene_file

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_committed_schema_is_up_to_date(name: str) -> None:
    path = ROOT / "schemas" / schema_file(name)
    assert path.exists(), f"{path} is missing: run `bowlrec schema --out schemas` to write it"
    assert path.read_text(encoding="utf-8") == SCHEMAS[name](), (
        f"{path} differs from the model's JSON Schema: run `bowlrec schema --out schemas` "
        "to regenerate it"
    )


def test_committed_schemas_are_all_generated() -> None:
    """No file in schemas/ is left over from a schema that no longer exists."""
    committed = sorted(p.name for p in (ROOT / "schemas").glob("*.schema.json"))
    assert committed == sorted(schema_file(n) for n in SCHEMAS)


def test_export_schemas(tmp_path: Path) -> None:
    paths = export_schemas(tmp_path / "out")
    assert sorted(p.name for p in paths) == sorted(schema_file(n) for n in SCHEMAS)
    assert all(p.read_text().endswith("}\n") for p in paths)


def test_committed_paper_examples_are_up_to_date(tmp_path: Path) -> None:
    fresh = {p.name: p.read_text(encoding="utf-8") for p in write_paper_examples(tmp_path)}
    committed_dir = ROOT / "examples" / "paper"
    committed = {p.name: p.read_text(encoding="utf-8") for p in committed_dir.glob("case*.json")}
    assert sorted(committed) == sorted(fresh), "run bowlrec.paper.write_paper_examples"
    for name, text in fresh.items():
        assert committed[name] == text, (
            f"examples/paper/{name} is stale: run "
            "`python -c 'from bowlrec.paper import write_paper_examples as w; "
            'w("examples/paper")\'`'
        )


@pytest.mark.parametrize("case", [c.case for c in TABLE_III])
def test_paper_examples_load_back(case: int) -> None:
    loaded = parse_scene_file(ROOT / "examples" / "paper" / f"case{case:02d}.json").scene
    assert loaded == paper_scene(case)
