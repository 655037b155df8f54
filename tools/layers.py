"""The package's layers, written once, and a check that its imports keep to them.

Data flows one way (docs/architecture.md): a module may import its own unit (the package or
module it belongs to) and the units of lower floors, never a unit of its own floor or above, and
no chain of imports may lead back to where it started. Imports are read from the source
(:mod:`ast`), at module level and inside functions alike; imports under ``if TYPE_CHECKING:``
are type-only and allowed anywhere but in the two lowest floors. A string constant that is the
whole dotted name of a bowlrec module (a format's writer module in ``bowlrec.sinks.registry``,
an importlib target) counts as an import of it.

``python -m tools.layers`` prints the floors and every breach (exit 1 if any);
``python -m tools.layers --update-docs`` writes the floors into docs/architecture.md's
``layers`` block; ``tests/test_layers.py`` runs the check in the default test tier.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "bowlrec"

#: the floors, bottom first: (name, units on it, what they do). A unit is a subpackage or a
#: module of bowlrec; units on one floor do not import each other.
FLOORS: list[tuple[str, tuple[str, ...], str]] = [
    (
        "constants",
        ("bowlrec.versions", "bowlrec.units", "bowlrec.errors"),
        "version constants, unit conversions and units of stored quantities, the error tree",
    ),
    (
        "ground",
        ("bowlrec.atomic_files", "bowlrec.provenance", "bowlrec.suggest", "bowlrec.file_kinds"),
        "atomic file writes; what produced a run (versions, platform); close names for an "
        "unknown one; which kind of file a mapping is and which command reads it",
    ),
    ("numerics", ("bowlrec.core",), "compiled kernels on plain floats: Plan in, Trajectory out"),
    ("scene", ("bowlrec.spec",), "Pydantic scene models in SI units, resolve() -> Plan"),
    ("paper", ("bowlrec.paper",), "the paper's Table III scenes and printed values"),
    (
        "references",
        ("bowlrec.paper_table", "bowlrec.testing"),
        "Table III compared; reference deliveries and the paper's RK4 scheme",
    ),
    (
        "pins",
        ("bowlrec.pins",),
        "the pin deck: pins, pin action (MuJoCo), leaves, scoring, spare targets",
    ),
    ("bowlers", ("bowlrec.bowling",), "bowlers' language: balls, layouts, deliveries, oil, aim"),
    (
        "figures",
        ("bowlrec.figures",),
        "every picture (matplotlib) from the data below",
    ),
    (
        "formats",
        ("bowlrec.sinks",),
        "one run written as HDF5, CSV, MCAP, rerun, NPZ, JSON (PNG/SVG: figures)",
    ),
    ("intake", ("bowlrec.scene_input",), "the one way in for a scene: file or mapping -> Scene"),
    ("archive", ("bowlrec.archive",), "segments, the index, the ball library, repair"),
    ("front door", ("bowlrec.api",), "simulate a scene; simulate into an archive"),
    ("batch", ("bowlrec.batch",), "jobs, sweeps, chunk workers, Dask"),
    ("sessions", ("bowlrec.session",), "bowlers on one lane whose oil changes shot by shot"),
    ("web pages", ("bowlrec.web",), "HTML pages, the runs table, the rerun viewer's files"),
    ("service", ("bowlrec.service",), "the HTTP service (FastAPI)"),
    ("command line", ("bowlrec.cli", "bowlrec"), "the bowlrec command; the package's front names"),
]


@dataclass(frozen=True)
class Import:
    """One import of a bowlrec module by another, where the source says it."""

    importer: str
    imported: str
    path: Path
    line: int

    def __str__(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}: {self.importer} -> {self.imported}"


def module_names(package: Path = PACKAGE) -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its ``__init__.py``)."""
    names: dict[str, Path] = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names[".".join(parts)] = path
    return names


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _nearest_module(name: str, modules: dict[str, Path]) -> str | None:
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(
    module: str, modules: dict[str, Path], *, type_only: bool = False
) -> Iterator[Import]:
    """The runtime imports of bowlrec modules in ``module``; with ``type_only`` the imports
    under ``if TYPE_CHECKING:`` too."""
    path = modules[module]
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]

    def targets(node: ast.AST) -> Iterator[tuple[str, int]]:
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package
                for _ in range(node.level - 1):
                    anchor = anchor.rpartition(".")[0]
                base = f"{anchor}.{base}" if base else anchor
            for alias in node.names:
                full = f"{base}.{alias.name}"
                yield (full if full in modules else base), node.lineno
        elif (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and node.value in modules
            and node.value != "bowlrec"
        ):
            yield node.value, node.lineno

    def walk(node: ast.AST) -> Iterator[tuple[str, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking(child) and not type_only:
                for other in child.orelse:
                    yield from targets(other)
                    yield from walk(other)
                continue
            yield from targets(child)
            yield from walk(child)

    for name, line in walk(tree):
        if name == "bowlrec" or name.startswith("bowlrec."):
            target = _nearest_module(name, modules)
            if target is not None and target != module:
                yield Import(module, target, path, line)


def unit_of(module: str) -> str:
    """The unit a module belongs to: the longest unit name that contains it."""
    units = [u for _, floor, _ in FLOORS for u in floor]
    found = [u for u in units if module == u or module.startswith(u + ".")]
    if not found:
        raise KeyError(f"{module} belongs to no unit of tools/layers.py FLOORS")
    return max(found, key=len)


def floor_of(unit: str) -> int:
    """The floor of a unit (0 the lowest)."""
    return next(i for i, (_, units, _) in enumerate(FLOORS) if unit in units)


def all_imports(package: Path = PACKAGE, *, type_only: bool = False) -> list[Import]:
    """Every import of a bowlrec module by another (``type_only``: the type-only ones too)."""
    modules = module_names(package)
    return [imp for m in modules for imp in imports_of(m, modules, type_only=type_only)]


def upward_imports(imports: list[Import]) -> list[Import]:
    """Imports of a unit on the same floor or above (an import within one unit is allowed)."""
    breaches = []
    for imp in imports:
        a, b = unit_of(imp.importer), unit_of(imp.imported)
        if a != b and floor_of(b) >= floor_of(a):
            breaches.append(imp)
    return breaches


def circles(imports: list[Import]) -> list[list[str]]:
    """Every set of modules that import each other in a circle (strongly connected
    components of more than one module), each sorted."""
    graph: dict[str, set[str]] = {}
    for imp in imports:
        graph.setdefault(imp.importer, set()).add(imp.imported)
        graph.setdefault(imp.imported, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def connect(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                connect(v)
    finally:
        sys.setrecursionlimit(limit)
    return found


def grounded_type_imports(package: Path = PACKAGE) -> list[Import]:
    """Type-only imports from the two lowest floors to a higher one: the constants and the
    ground import nothing of the floors above, not even for annotations."""
    ground = {u for _, units, _ in FLOORS[:2] for u in units}
    return [
        imp
        for imp in upward_imports(all_imports(package, type_only=True))
        if unit_of(imp.importer) in ground
    ]


def unplaced(package: Path = PACKAGE) -> list[str]:
    """Modules that belong to no unit of :data:`FLOORS`."""
    out = []
    for module in module_names(package):
        try:
            unit_of(module)
        except KeyError:
            out.append(module)
    return out


def markdown() -> str:
    """The floors as a Markdown table, top floor first (docs/architecture.md)."""
    rows = ["| floor | units | what they do |", "|---|---|---|"]
    for i, (name, units, what) in reversed(list(enumerate(FLOORS))):
        names = ", ".join(f"`{u}`" for u in units)
        rows.append(f"| {i} {name} | {names} | {what} |")
    return "\n".join(rows) + "\n"


def main(argv: list[str]) -> int:
    if "--update-docs" in argv:
        from tools.readme_blocks import block_path, replace_block

        changed = replace_block(block_path("layers"), "layers", markdown())
        print(f"{block_path('layers')}: {'updated' if changed else 'unchanged'}")
        return 0
    imports = all_imports()
    problems = [f"{m}: in no unit of FLOORS" for m in unplaced()]
    problems += [f"upward: {imp}" for imp in upward_imports(imports)]
    problems += [f"circle: {' <-> '.join(c)}" for c in circles(imports)]
    problems += [f"ground reaches up (type-only): {imp}" for imp in grounded_type_imports()]
    for name, units, _ in reversed(FLOORS):
        print(f"{name:>14}: {', '.join(units)}")
    for line in problems:
        print(line)
    print(f"{len(imports)} imports read; {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
