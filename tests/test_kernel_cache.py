"""The numba cache entries dropped when sources change (bowlrec.core._kernel_cache) and the one
kernel warm-up (bowlrec.core.warm, bowlrec.testing.warm).

The dependency sets are checked on bowlrec's own modules; the drops in a scratch package with a
scratch cache directory holding fake ``.nbi``/``.nbc`` entries (nothing is compiled). The test
with several processes checking at once is in the ``process`` tier.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import bowlrec
from bowlrec.core import _kernel_cache as kc
from bowlrec.core._kernel_cache import STAMP, drop_stale_kernels, kernel_dependencies
from bowlrec.core.warm import GROUPS, VARIANTS, WarmUp, warm_up

PACKAGE = Path(bowlrec.__file__).resolve().parent
CORE = PACKAGE / "core"


def _names(paths: list[Path]) -> set[str]:
    """Paths of bowlrec modules as "core/dynamics", "errors"..."""
    return {p.relative_to(PACKAGE).with_suffix("").as_posix() for p in paths}


# -- dependency sets of bowlrec's modules ------------------------------------------------------


@pytest.mark.parametrize(
    ("module", "imports"),
    [
        (
            "core/integrator.py",
            {
                "core/codes",
                "core/contact",
                "core/tsit5",
                "core/dynamics",
                "core/events",
                "core/observe",
                "core/recording",
                "core/records",
                "core/step_control",
                "core/vec",
            },
        ),
        ("core/summary.py", {"core/codes", "core/contact", "core/trajectory"}),
        ("core/trajectory.py", {"errors"}),  # pandas: under TYPE_CHECKING, and no bowlrec module
        ("core/vec.py", set()),  # `from . import _kernel_cache`: the check, no kernel's code
        ("core/recording.py", {"core/codes"}),
        ("testing/rk4.py", {"core/codes", "core/dynamics", "core/plan", "core/arguments"}),
    ],
)
def test_module_imports_are_the_bowlrec_modules_imported_at_module_level(
    module: str, imports: set[str]
) -> None:
    assert _names(kc.module_imports(PACKAGE / module)) == imports


_FROM = re.compile(r"^from (\.?)([\w.]*) import ([^\n#]*)", re.MULTILINE)


@pytest.mark.parametrize("path", sorted(CORE.glob("*.py")), ids=lambda p: p.name)
def test_module_imports_agree_with_the_import_lines_of_each_core_module(path: Path) -> None:
    """Another reading: the unindented ``from`` lines (core modules import nothing else at
    module level; indented ones are under TYPE_CHECKING or in functions)."""
    expected = set()
    for dot, module, names in _FROM.findall(path.read_text()):
        if dot and not module:  # from . import x
            expected |= {f"core/{n.strip(' ()')}" for n in names.split(",") if n.strip(" ()")}
        elif dot:
            expected.add(f"core/{module}")
        elif module.startswith("bowlrec."):
            expected.add(module.removeprefix("bowlrec.").replace(".", "/"))
    expected.discard("core/_kernel_cache")
    expected.discard(f"core/{path.stem}")
    assert _names(kc.module_imports(path)) == expected


def test_kernel_dependencies_follow_imports_transitively() -> None:
    deps = {m: _names(paths) for m, paths in kernel_dependencies(CORE).items()}
    assert "solver" not in deps and "warm" not in deps and "codes" not in deps  # no kernels
    assert deps["vec"] == {"core/vec"}
    assert deps["recording"] == {"core/recording", "core/codes"}
    assert deps["dynamics"] == {"core/dynamics", "core/codes", "core/vec"}
    assert {"core/observe", "core/tsit5", "core/dynamics", "core/vec"} <= deps["integrator"]
    # summary freezes trajectory's metric names; batch reaches the Python-only arguments (and
    # through summary, trajectory), not solver or outcome
    assert {"core/trajectory", "errors"} <= deps["summary"]
    assert {"core/arguments", "core/trajectory", "core/integrator"} <= deps["batch"]
    assert not {"core/solver", "core/outcome"} & deps["batch"]
    assert not any("core/warm" in d for d in deps.values())
    testing = kernel_dependencies(PACKAGE / "testing")
    assert set(testing) == {"rk4"}
    assert {"core/arguments", "core/dynamics", "core/topography"} <= _names(testing["rk4"])
    assert not {"core/solver", "core/integrator"} & _names(testing["rk4"])


def test_the_cache_dir_is_the_one_numba_uses() -> None:
    from bowlrec.core.dynamics import rhs

    assert kc.kernel_cache_dir(CORE) == Path(rhs._cache.cache_path)
    assert kc.LAST.cache_dir == Path(rhs._cache.cache_path) and kc.LAST.checked


# -- drops in a scratch package ----------------------------------------------------------------

#: a package "pkg" whose directory "kern" has the kernel modules leaf, mid, top and guarded
SOURCES = {
    "pkg/__init__.py": "",
    "pkg/util.py": "SCALE = 2.0\n",
    "pkg/kern/__init__.py": "LIMIT = 3\n",
    "pkg/kern/consts.py": "N = 4\n",
    "pkg/kern/leaf.py": (
        "from numba import njit\n\nfrom .consts import N\n\n\n"
        "@njit(cache=True)\ndef f(x):\n    return x * N\n"
    ),
    "pkg/kern/mid.py": (
        "from numba import njit\n\nfrom . import leaf\n\n\n"
        "@njit(cache=True, error_model='numpy')\ndef f(x):\n    return leaf.f(x)\n"
    ),
    "pkg/kern/helper.py": (  # Python only; its lazy import reaches no kernel
        "from ..util import SCALE\n\nK = SCALE * 2\n\n\ndef g():\n    from . import lonely\n"
    ),
    "pkg/kern/top.py": (
        "import numba\n\nimport pkg.kern.mid as mid\nfrom .helper import K\n\n\n"
        "@numba.njit\ndef f(x):\n    return mid.f(x) + K\n"
    ),
    "pkg/kern/guarded.py": (
        "from typing import TYPE_CHECKING\n\nimport numba\n\nif TYPE_CHECKING:\n"
        "    from . import lonely\ntry:\n    from . import LIMIT\nexcept ImportError:\n"
        "    LIMIT = 1\n\n\n@numba.jit(nopython=True, cache=True)\ndef f(x):\n"
        "    return x + LIMIT\n"
    ),
    "pkg/kern/lonely.py": "Z = 1\n",
}
KERNELS = ("guarded", "leaf", "mid", "top")


def _scratch(tmp_path: Path) -> tuple[Path, Path]:
    """The scratch package's kernel directory and an empty cache directory (stamp written)."""
    for name, text in SOURCES.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    cache = tmp_path / "cache"
    cache.mkdir()
    kern = tmp_path / "pkg" / "kern"
    first = drop_stale_kernels(kern, cache)
    assert first.checked and first.modules == [] and (cache / STAMP).is_file()
    return kern, cache


def _entries(cache: Path, modules: tuple[str, ...] = KERNELS) -> set[str]:
    """Fake numba entries of ``modules`` (an index and a data file each), and a temporary file
    numba might be writing; returns the entries' names."""
    names = set()
    for m in modules:
        for suffix in ("nbi", "1.nbc"):
            (cache / f"{m}.f-7.py311.{suffix}").write_bytes(b"x")
            names.add(f"{m}.f-7.py311.{suffix}")
    (cache / "leaf.f-7.py311.nbi.tmp.3f2a").write_bytes(b"x")
    return names


def _left(cache: Path) -> set[str]:
    return {p.name for p in cache.iterdir() if p.suffix in (".nbi", ".nbc")}


def _append(path: Path) -> None:
    path.write_text(path.read_text() + "# edited\n")


def test_the_dependency_sets_of_the_scratch_package(tmp_path: Path) -> None:
    kern, _ = _scratch(tmp_path)
    deps = {m: {p.relative_to(tmp_path).as_posix() for p in d} for m, d in
            kernel_dependencies(kern).items()}  # fmt: skip
    assert deps == {
        "leaf": {"pkg/kern/leaf.py", "pkg/kern/consts.py"},
        "mid": {"pkg/kern/mid.py", "pkg/kern/leaf.py", "pkg/kern/consts.py"},
        "top": {
            "pkg/kern/top.py",
            "pkg/kern/mid.py",
            "pkg/kern/leaf.py",
            "pkg/kern/consts.py",
            "pkg/kern/helper.py",
            "pkg/util.py",
        },
        "guarded": {"pkg/kern/guarded.py", "pkg/kern/__init__.py"},
    }


@pytest.mark.parametrize(
    ("edited", "dropped"),
    [
        ("pkg/kern/consts.py", ["leaf", "mid", "top"]),  # Python only, constants frozen
        ("pkg/kern/leaf.py", ["leaf", "mid", "top"]),
        ("pkg/kern/mid.py", ["mid", "top"]),
        ("pkg/kern/top.py", ["top"]),
        ("pkg/kern/helper.py", ["top"]),
        ("pkg/util.py", ["top"]),  # outside the directory, reached through helper
        ("pkg/kern/__init__.py", ["guarded"]),  # `from . import LIMIT`
        ("pkg/kern/lonely.py", []),  # imported lazily or under TYPE_CHECKING only
        ("pkg/__init__.py", []),
    ],
)
def test_an_edit_drops_the_entries_of_the_modules_depending_on_it(
    tmp_path: Path, edited: str, dropped: list[str]
) -> None:
    kern, cache = _scratch(tmp_path)
    entries = _entries(cache)
    assert drop_stale_kernels(kern, cache).modules == []  # current: nothing to do
    _append(tmp_path / edited)
    done = drop_stale_kernels(kern, cache)
    assert done.checked and done.modules == dropped and done.files == 2 * len(dropped)
    assert _left(cache) == {e for e in entries if e.split(".")[0] not in dropped}
    assert (cache / "leaf.f-7.py311.nbi.tmp.3f2a").exists()  # numba's temporaries: untouched
    recorded = json.loads((cache / STAMP).read_text())["files"]  # the stamp of the edited sources
    if edited == "pkg/__init__.py":  # no module of the directory, no dependency: not recorded
        assert edited not in recorded
    else:
        assert recorded[edited] == kc._sha256(tmp_path / edited)
    again = drop_stale_kernels(kern, cache)
    assert again.checked and again.modules == []


def test_a_missing_stamp_drops_every_entry_and_other_modules_entries_go(tmp_path: Path) -> None:
    kern, cache = _scratch(tmp_path)
    _entries(cache, (*KERNELS, "consts", "gone"))  # consts has no kernels, gone no file
    (cache / STAMP).write_text("{not json")
    assert drop_stale_kernels(kern, cache).modules == sorted((*KERNELS, "consts", "gone"))
    assert _left(cache) == set()
    entries = _entries(cache, (*KERNELS, "consts"))
    assert drop_stale_kernels(kern, cache).modules == []  # entries of no kernel module stay
    assert _left(cache) == entries  # until the next change
    _append(kern / "lonely.py")
    assert drop_stale_kernels(kern, cache).modules == ["consts"]


def test_removed_added_and_unparsable_modules(tmp_path: Path) -> None:
    kern, cache = _scratch(tmp_path)
    _entries(cache)
    (kern / "leaf.py").unlink()  # mid and top lose a dependency, leaf is no kernel module
    assert drop_stale_kernels(kern, cache).modules == ["leaf", "mid", "top"]
    _entries(cache)
    (kern / "new.py").write_text("from .consts import N\n")  # a new module: a new stamp
    assert drop_stale_kernels(kern, cache).modules == ["leaf"]
    assert "pkg/kern/new.py" in json.loads((cache / STAMP).read_text())["files"]
    _entries(cache)
    (kern / "mid.py").write_text("def broken(:\n")  # being edited: no kernels, nothing raised
    assert drop_stale_kernels(kern, cache).modules == ["leaf", "mid", "top"]


def test_a_missing_cache_dir_does_nothing(tmp_path: Path) -> None:
    kern, _ = _scratch(tmp_path)
    done = drop_stale_kernels(kern, tmp_path / "no" / "cache")
    assert not done.checked and done.modules == [] and not (tmp_path / "no").exists()
    assert drop_stale_kernels(tmp_path / "empty-dir").cache_dir is None  # no modules, no cache


def test_a_read_only_cache_dir_does_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    kern, cache = _scratch(tmp_path)
    entries = _entries(cache)
    _append(kern / "consts.py")
    stamp = (cache / STAMP).read_bytes()
    cache.chmod(0o555)
    try:
        if os.geteuid() == 0:  # root writes anyway: make the directory read-only as a read-only
            real = os.access  # mount is, for os.access

            def access(path: object, mode: int, **kw: object) -> bool:
                ro = mode & os.W_OK and Path(str(path)) == cache
                return False if ro else real(path, mode, **kw)  # type: ignore[arg-type]

            monkeypatch.setattr(os, "access", access)
        done = drop_stale_kernels(kern, cache)
    finally:
        cache.chmod(0o755)
    assert not done.checked and done.modules == [] and _left(cache) == entries
    assert (cache / STAMP).read_bytes() == stamp


def test_a_cache_dir_failing_midway_raises_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A directory turning read-only (or vanishing) between the check and the drop."""
    kern, cache = _scratch(tmp_path)
    _entries(cache)
    _append(kern / "consts.py")

    def refuse(*args: object, **kwargs: object) -> int:
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(kc.os, "open", refuse)
    done = drop_stale_kernels(kern, cache)
    assert not done.checked and done.modules == []


CHILD = """
import json, sys, time
from pathlib import Path
from bowlrec.core._kernel_cache import drop_stale_kernels
kern, cache, go = (Path(a) for a in sys.argv[1:4])
print("ready", flush=True)
while not go.exists():
    time.sleep(0.0005)
done = drop_stale_kernels(kern, cache)
print(json.dumps({"checked": done.checked, "modules": done.modules, "files": done.files}))
"""


@pytest.mark.process
def test_processes_checking_at_once_drop_once_and_leave_a_consistent_stamp(
    tmp_path: Path,
) -> None:
    kern, cache = _scratch(tmp_path)
    for round_ in range(3):
        _entries(cache)
        _append(kern / "consts.py")
        go = tmp_path / f"go{round_}"
        procs = [
            subprocess.Popen(
                [sys.executable, "-c", CHILD, str(kern), str(cache), str(go)],
                stdout=subprocess.PIPE,
                text=True,
            )
            for _ in range(4)
        ]
        for p in procs:
            assert p.stdout is not None and p.stdout.readline() == "ready\n"
        go.touch()
        results = [json.loads(p.communicate(timeout=60)[0]) for p in procs]
        assert all(r["checked"] for r in results)
        assert sorted(r["modules"] for r in results) == [[], [], [], ["leaf", "mid", "top"]]
        assert sum(r["files"] for r in results) == 6
        assert _left(cache) == {f"guarded.f-7.py311.{s}" for s in ("nbi", "1.nbc")}
        assert kc._current(kern, tmp_path / "pkg", kc._read_stamp(cache))
        assert not list(cache.glob(f"{STAMP}.tmp.*"))


# -- the warm-up -------------------------------------------------------------------------------


def test_warm_up_a_group_runs_its_variants_and_counts_kernels() -> None:
    first = warm_up("service")
    assert first.names == GROUPS["service"] == ("closed_form", "integrator", "batch_serial")
    assert first.compiled >= 0 and first.loaded >= 0 and first.seconds >= 0
    again = warm_up("service", "integrator")  # in memory now: nothing compiled or loaded
    assert again.names == GROUPS["service"] and (again.compiled, again.loaded) == (0, 0)
    assert str(again).startswith("kernel warm-up: ") and "0 kernels compiled" in str(again)


def test_warm_up_names_groups_and_extra_variants() -> None:
    ran: list[str] = []
    done = warm_up("batch", extra={"mine": lambda: ran.append("mine")})
    assert done.names == ("integrator", "batch_serial") and ran == []
    done = warm_up("all", extra={"mine": lambda: ran.append("mine")})
    assert done.names == (*VARIANTS, "mine") and ran == ["mine"]
    with pytest.raises(ValueError, match="unknown kernel variant 'nope'"):
        warm_up("service", "nope")
    assert isinstance(done, WarmUp) and done.as_dict()["names"] == done.names


@pytest.mark.process
def test_the_warm_up_command_loads_the_kernels_in_a_fresh_process(
    pytestconfig: pytest.Config,
) -> None:
    """The kernels are on disk (the session's warm-up): a fresh process loads, compiles none."""
    if pytestconfig.getoption("no_kernel_warm_up"):
        pytest.skip("needs the session's kernel warm-up (the kernels on disk)")
    out = subprocess.run(
        [sys.executable, "-m", "bowlrec.testing.warm", "--json", "service", "rk4"],
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    ).stdout
    result = json.loads(out)
    assert result["names"] == [*GROUPS["service"], "rk4"]
    assert result["compiled"] == 0 and result["loaded"] >= 5
