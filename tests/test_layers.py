"""The imports keep to the layers of tools/layers.py: no circle, nothing reaches up.

The floors are written once, in ``tools.layers.FLOORS``; docs/architecture.md shows them as a
generated block. The check itself is tested on a small package made here, so a check that
could no longer see a breach fails too.
"""

from __future__ import annotations

from pathlib import Path

from tools import layers


def test_every_module_belongs_to_a_floor() -> None:
    assert layers.unplaced() == []


def test_no_import_reaches_up_or_sideways() -> None:
    breaches = layers.upward_imports(layers.all_imports())
    assert not breaches, "imports of a higher or the same floor:\n" + "\n".join(map(str, breaches))


def test_no_import_circle() -> None:
    found = layers.circles(layers.all_imports())
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_the_ground_imports_nothing_above_it_even_for_types() -> None:
    found = layers.grounded_type_imports()
    assert not found, "\n".join(map(str, found))


def _package(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "bowlrec" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root / "bowlrec"


def test_the_check_sees_a_circle_an_upward_import_and_a_typed_ground_import(
    tmp_path: Path,
) -> None:
    package = _package(
        tmp_path,
        {
            "__init__.py": "",
            "errors.py": (
                "from typing import TYPE_CHECKING\n"
                "if TYPE_CHECKING:\n    from bowlrec.bowling.ball import Ball\n"
            ),
            "core/__init__.py": "",
            "core/a.py": "def f():\n    from .b import g\n",
            "core/b.py": "from bowlrec.core import a\n",
            "spec/__init__.py": "",
            "spec/scene.py": "def f():\n    from bowlrec.archive.store import Archive\n",
            "bowling/__init__.py": "",
            "bowling/ball.py": (
                "from typing import TYPE_CHECKING\n"
                "if TYPE_CHECKING:\n    from bowlrec.cli import app\n"
            ),
            "archive/__init__.py": "",
            "archive/store.py": "MODULE = 'bowlrec.core.a'\n",
            "cli/__init__.py": "",
        },
    )
    imports = layers.all_imports(package)
    assert layers.circles(imports) == [["bowlrec.core.a", "bowlrec.core.b"]]
    upward = [(i.importer, i.imported, i.line) for i in layers.upward_imports(imports)]
    assert upward == [("bowlrec.spec.scene", "bowlrec.archive.store", 2)]
    typed = [(i.importer, i.imported) for i in layers.grounded_type_imports(package)]
    assert typed == [("bowlrec.errors", "bowlrec.bowling.ball")]
    # a module path named in a string is an import (a format registry's writer module)
    assert ("bowlrec.archive.store", "bowlrec.core.a") in {
        (i.importer, i.imported) for i in imports
    }


def test_the_architecture_page_shows_the_floors() -> None:
    """docs/architecture.md's ``layers`` block is the table of FLOORS
    (``python -m tools.layers --update-docs`` writes it)."""
    from tools.readme_blocks import block_path, read_block

    assert read_block(block_path("layers"), "layers") == layers.markdown()
