"""A fresh ``bowlrec simulate``: the command imports only its own command module, loads only the
kernel it runs, and loads it without numba's full refresh; the results are the same bits."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import typer.main

from bowlrec.cli import COMMANDS, MODULES, app

ROOT = Path(__file__).resolve().parents[1]
CASE16 = ROOT / "examples" / "paper" / "case16.json"


def test_every_command_is_mapped_to_the_module_registering_it() -> None:
    group = typer.main.get_command(app)
    assert isinstance(group, typer.main.TyperGroup)
    registered = set(group.commands)
    assert set(COMMANDS) == registered
    assert set(COMMANDS.values()) == set(MODULES)
    for name, command in group.commands.items():
        callback = getattr(command, "callback", None)
        if callback is not None:  # a command; a group (balls, runs...) has none
            assert callback.__module__ == f"bowlrec.cli.{COMMANDS[name]}", name


def _fresh(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return out.stdout.strip().splitlines()[-1]


#: runs ``bowlrec ARGS`` through the entry point, then prints which command modules it imported
MAIN = """
import sys
sys.argv = ["bowlrec", *{args!r}]
from bowlrec.cli import main
try:
    main()
except SystemExit:
    pass
print(sorted(m.rsplit(".", 1)[1] for m in sys.modules if m.startswith("bowlrec.cli.")
             and not m.rsplit(".", 1)[1].startswith("_")))
"""


@pytest.mark.process  # a fresh interpreter's modules
@pytest.mark.parametrize(
    ("args", "modules"),
    [
        (["simulate", "--help"], ["scenes"]),
        (["runs", "--help"], ["runs"]),
        (["--help"], sorted(MODULES)),
        (["no-such-command"], sorted(MODULES)),
    ],
)
def test_main_imports_the_command_module_it_runs(args: list[str], modules: list[str]) -> None:
    assert _fresh(MAIN.format(args=args)) == repr(modules)


#: one delivery of case 16 in a fresh process (summary only, or every step with the terms): the
#: kernels loaded from numba's cache, the cache class of the integrator, and the result's bits
RUN = """
import dataclasses, hashlib, json, sys
import numpy as np
{before}
from bowlrec.core import solver
from bowlrec.core.codes import RECORD_STEPS, RECORD_SUMMARY
from bowlrec.core.warm import kernels
from bowlrec.scene_input import parse_scene_file
plan = parse_scene_file({path!r}).scene.resolve()
mode = {{"summary": RECORD_SUMMARY, "steps": RECORD_STEPS}}[{mode!r}]
traj = solver.run_plan(dataclasses.replace(plan, record_mode=mode, record_terms=True))
loaded = sorted(k.__name__ for k in kernels() if sum(k.stats.cache_hits.values()))
h = hashlib.sha256(repr(traj.summary).encode() + repr(traj.events).encode())
for f in dataclasses.fields(traj):
    v = getattr(traj, f.name)
    for a in (v.values() if isinstance(v, dict) else [v]):
        if isinstance(a, np.ndarray):
            h.update(f.name.encode() + str(a.shape).encode() + np.ascontiguousarray(a).tobytes())
import numba
from numba.np import arraymath
blas = arraymath._HAVE_BLAS
scipy_linalg = "scipy.linalg" in sys.modules
assert numba.njit(lambda x: x + 1)(1) == 2  # compiling still works after a lean load
import llvmlite.binding as ll
library = next(iter(solver.simulate_kernel.overloads.values())).library
module = library._get_module_for_linking()  # a lean load parses its bitcode now
hidden = (ll.Linkage.private, ll.Linkage.internal)
exported = {{g.name for gs in (module.functions, module.global_variables) for g in gs
            if not g.is_declaration and g.linkage not in hidden}}
symbols_known = bool(exported) and exported <= library._codegen._engine._defined_symbols
if blas:  # and numba's own BLAS check runs when a BLAS call is compiled
    assert numba.njit(lambda a: np.dot(a, a))(np.ones(3)) == 3.0
print(json.dumps([loaded, type(solver.simulate_kernel._cache).__name__, h.hexdigest(), blas,
                  scipy_linalg, type(library).__name__, symbols_known]))
"""
#: disables the lean load (numba's own load, with its refresh) in a fresh process
FULL_LOAD = "import bowlrec.core._kernel_cache as kc; kc.load_lean = lambda *kernels: None"


@pytest.mark.process  # fresh interpreters: what loads from numba's cache
@pytest.mark.parametrize(
    ("mode", "kernels"),
    [("summary", ["simulate_kernel"]), ("steps", ["derive_samples", "simulate_kernel"])],
)
def test_a_fresh_process_loads_only_what_it_runs_and_the_bits_are_numbas(
    pytestconfig: pytest.Config, mode: str, kernels: list[str]
) -> None:
    if pytestconfig.getoption("no_kernel_warm_up"):
        pytest.skip("needs the session's kernel warm-up (the kernels on disk)")
    lean = json.loads(_fresh(RUN.format(before="", path=str(CASE16), mode=mode)))
    full = json.loads(_fresh(RUN.format(before=FULL_LOAD, path=str(CASE16), mode=mode)))
    assert lean[0] == full[0] == kernels
    assert (lean[1], full[1]) == ("LeanFunctionCache", "FunctionCache")
    assert lean[2] == full[2]
    assert lean[3] == full[3]  # numba's answer to "is there BLAS?", without importing scipy
    assert not lean[4]
    assert full[4] == full[3]  # numba's own probe imports scipy.linalg where scipy is there
    # the lean load takes the symbols from the object file and parses the bitcode when asked:
    # every symbol the bitcode defines for other modules is known to the engine, as after
    # numba's own load
    assert (lean[5], full[5]) == ("LeanLibrary", "JITCodeLibrary")
    assert lean[6] and full[6]


def test_the_blas_probe_gives_numbas_answer() -> None:
    from bowlrec.core._kernel_cache import _blas_present

    try:
        import scipy.linalg.cython_blas  # noqa: F401  (numba's probe)
    except ImportError:
        with pytest.raises(ImportError):
            _blas_present()
    else:
        _blas_present()


def test_load_lean_leaves_other_caches_alone() -> None:
    from numba import njit

    from bowlrec.core._kernel_cache import load_lean

    plain = njit(lambda x: x)  # no cache=True: numba's NullCache
    before = type(plain._cache)
    load_lean(plain, object())
    assert type(plain._cache) is before


#: a cached kernel in its own module (``tiny.py``)
TINY = """
import numba

@numba.njit(cache=True)
def scaled(x, k):
    return 3.0 * x + k
"""

#: loads ``tiny.scaled`` (lean), then compiles a kernel that calls (links) it
LINK = """
import sys
sys.path.insert(0, {folder!r})
import numba
from bowlrec.core._kernel_cache import load_lean
import tiny
load_lean(tiny.scaled)
first = tiny.scaled(2.0, 1)
hits = sum(tiny.scaled.stats.cache_hits.values())
library = type(next(iter(tiny.scaled.overloads.values())).library).__name__

@numba.njit
def caller(x):
    return tiny.scaled(x, 2) + tiny.scaled(x, 1)

print(first, hits, library, caller(1.5))
"""


@pytest.mark.process  # fresh interpreters: a kernel compiled in one, loaded in the next
def test_a_kernel_compiled_later_links_a_lean_loaded_one(tmp_path: Path) -> None:
    """A kernel loaded lean keeps its bitcode unparsed until a kernel compiled later calls it;
    then numba links it as after its own load."""
    (tmp_path / "tiny.py").write_text(TINY)
    code = LINK.format(folder=str(tmp_path))
    _fresh(code)  # compiles tiny.scaled and writes its cache entry
    first, hits, library, linked = _fresh(code).split()
    assert (float(first), int(hits), library) == (7.0, 1, "LeanLibrary")
    assert float(linked) == 3.0 * 1.5 + 2 + 3.0 * 1.5 + 1


def test_symbols_are_read_only_from_64_bit_little_endian_elf_objects() -> None:
    from bowlrec.core._lean_library import elf_defined_symbols

    assert elf_defined_symbols(b"") is None
    assert elf_defined_symbols(b"\xcf\xfa\xed\xfe" + bytes(60)) is None  # Mach-O
    assert elf_defined_symbols(b"\x7fELF\x01\x01" + bytes(58)) is None  # 32-bit
    header = bytearray(64)
    header[:6] = b"\x7fELF\x02\x01"
    header[0x10] = 1  # a relocatable object, its section table past the end of the file
    header[0x28:0x30] = (10_000).to_bytes(8, "little")
    header[0x3A:0x3E] = (64).to_bytes(2, "little") + (3).to_bytes(2, "little")
    assert elf_defined_symbols(bytes(header)) is None
    header[0x3C:0x3E] = bytes(2)  # no sections: no symbols
    assert elf_defined_symbols(bytes(header)) == set()
