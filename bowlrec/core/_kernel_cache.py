"""Drop the numba cache entries of kernels whose code may have changed, before any is loaded.

numba keys a cached kernel on its own source file only (the ``.nbi`` index holds a hash of that
file). A kernel compiles what it calls from other modules into itself (the integrator inlines
``dynamics.rhs``) and freezes the module constants it reads, including those it imports
(``N_STATE`` from ``codes``, ``FLOAT_METRICS`` from the Python-only ``trajectory``): after an
edit of another module, numba would serve a stale copy. The rule, per directory of modules:

* a **kernel module** is a module of the directory with a numba-decorated function (``@njit``,
  ``@numba.jit(...)``...: read with :mod:`ast`);
* its **dependencies** are its own file and, transitively, every module of its top package
  (``bowlrec``) it imports at module level: ``import bowlrec.x``, ``from .x import y``,
  ``from . import x``, ``from .. import x``, also inside ``if``/``try``/``with`` blocks; not
  under ``if TYPE_CHECKING:``, and not inside functions (a kernel cannot import, so a lazy
  import reaches Python code only). ``from . import NAME`` of a name defined in a package's
  ``__init__`` counts as that ``__init__``. This module is nobody's dependency: ``vec`` imports
  it to run the check, no kernel uses it;
* a kernel module's **dependency hash** is the SHA-256 over the paths and contents of its
  dependencies. Its cache entries (``<module>.<function>-<line>.py311[.N].nbi``/``.nbc``) are
  dropped when that hash differs from the one in the cache directory's stamp
  (``bowlrec-kernel-deps.json``); so are the entries of a module that is no kernel module. An
  edit of ``dynamics`` drops every kernel module importing it, directly or not; an edit of the
  Python-only ``arguments`` drops ``batch``, which imports it; an edit of a module no kernel
  module reaches (``solver``, ``outcome``, ``warm``) drops nothing.

The cache directory is the one numba picks for the directory's sources (``NUMBA_CACHE_DIR``,
else ``__pycache__`` beside them, else numba's user-wide cache when that one is read-only): numba
itself says which (:func:`kernel_cache_dir`). Where it is missing or read-only, nothing happens.

Cost: the stamp is current when the directory has the modules it records and every file it
records (the directory's modules and all dependencies) has the recorded content; checking that
is a read of the stamp, a listing and a hash of each file, about 1 ms for ``bowlrec/core``
(benchmarks/results/kernel_cache.md). Imports are parsed only when it is not.

Concurrency: a process whose check fails takes an exclusive ``flock`` on
``bowlrec-kernel-deps.lock`` in the cache directory, checks again (another process may have done
the work meanwhile), drops the stale entries, writes the new stamp (atomically, after the drops)
and releases the lock. A process loads kernels only after its own check passed, so no process
drops an entry that another one loaded or wrote for the same sources; numba's temporary files
(``*.tmp.*``) are never touched. What no check can see: a process that imported the sources
before an edit and compiles a new signature after another process's check writes an entry built
from the old sources. Restart long-running processes (a server, a pytest session) after editing
kernel code.

``vec`` runs :func:`check_core` when imported, and every kernel entry point (integrator, closed
form, batch) imports ``vec``, so the check of ``bowlrec/core`` runs once per process, before the
first kernel loads (its result: :data:`LAST`); importing this module checks nothing and imports
no numba. ``bowlrec.testing.rk4`` runs :func:`drop_stale_kernels` on its own directory.

Reading the cache without numba (``bowlrec.core.warm.missing``, the commands' first-use
notice): :func:`numba_cache_dir` is numba's choice of directory, found by numba's rule;
:func:`cached_signatures` reads a kernel's index file (``.nbi``: numba's version, then the
source stamp, a SHA-256 of the module's file, and the signatures it holds, each naming its data
file), with every numba type read as its name; :func:`stamp_current` tells whether the check
would drop anything.

Loading: before numba loads a kernel from its cache it refreshes its whole target context, which
imports and installs every implementation numba has (typed containers, random generators,
datetime, polynomials...) although a loaded kernel is machine code that calls none of them
through the context. :func:`load_lean` lets the kernels given to it load without that refresh:
numba's runtime (NRT, which kernels returning arrays allocate through) is initialized, the
entry is read and rebuilt as numba does it; the modules whose implementations a kernel uses are
imported when its entry is rebuilt (numba rebuilds each compiled function's environment from its
module). One of them, ``numba.np.arraymath`` (``np.searchsorted``), asks at import whether BLAS
is there by importing ``scipy.linalg.cython_blas``, which imports all of ``scipy.linalg``
wherever scipy is installed (scipy is no runtime dependency; the kernels use no BLAS,
tests/test_no_blas_in_kernels.py): the lean load imports it with that question answered by
looking for the extension module's file instead, the same answer in any working install, and
numba's own check (import and integer-width check) runs when something first compiles a BLAS
call. The entry's code library is :mod:`._lean_library`'s while it loads: its symbols come from
the object file, its linking bitcode is parsed only when a kernel compiled later links it. A
kernel that must be compiled still gets the refresh (numba's compiler does it first), so does
every other kernel (benchmarks/results/cold_start.md).
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import pickle
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "LAST",
    "STAMP",
    "Dropped",
    "cached_signatures",
    "check_core",
    "drop_stale_kernels",
    "kernel_cache_dir",
    "kernel_dependencies",
    "load_lean",
    "module_imports",
    "numba_cache_dir",
    "stamp_current",
]

#: the stamp of a cache directory: file hashes and each kernel module's dependency hash
STAMP = "bowlrec-kernel-deps.json"
#: the file processes lock before they drop entries or write the stamp
LOCK = "bowlrec-kernel-deps.lock"
#: the stamp's layout; a stamp of another layout counts as missing
FORMAT = 1
#: decorators that make a numba kernel (bare, called, or as attributes: ``numba.njit(...)``)
NUMBA_DECORATORS = frozenset({"njit", "jit", "vectorize", "guvectorize", "cfunc", "stencil"})
#: numba's cache files (never its ``*.tmp.*`` files, which another process may be writing)
CACHE_SUFFIXES = (".nbi", ".nbc")

#: this file, relative to its top package's parent ("bowlrec/core/_kernel_cache.py")
_SELF = "/".join(Path(__file__).resolve().parts[-3:])


@dataclass
class Dropped:
    """What :func:`drop_stale_kernels` did: the cache directory (None: numba has no writable
    one); ``checked``: the stamp was compared (False: missing or read-only directory, nothing
    done); ``modules``: the modules (file stems) whose entries were dropped, sorted; ``files``:
    the ``.nbi``/``.nbc`` files removed; ``seconds``: the time it took."""

    cache_dir: Path | None = None
    checked: bool = False
    modules: list[str] = field(default_factory=list)
    files: int = 0
    seconds: float = 0.0


def _top_package(directory: Path) -> Path:
    """The outermost package folder containing ``directory`` (module keys are relative to its
    parent: ``bowlrec/core/dynamics.py``)."""
    root = directory
    while (root.parent / "__init__.py").is_file():
        root = root.parent
    return root


def _modules(directory: Path, root: Path) -> list[Path]:
    """The modules of ``directory``, this one excepted."""
    return sorted(p for p in directory.glob("*.py") if _key(p, root) != _SELF)


def _key(path: Path, root: Path) -> str:
    return path.relative_to(root.parent).as_posix()


def _module_file(root: Path, dotted: list[str]) -> Path | None:
    """The file of the module ``dotted`` when it is in ``root``'s package: ``a/b.py`` or
    ``a/b/__init__.py``."""
    if not dotted or dotted[0] != root.name:
        return None
    base = root.parent.joinpath(*dotted)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _module_level(body: list[ast.stmt]) -> Iterator[ast.stmt]:
    """The statements run when the module loads: ``body`` and its ``if``/``try``/``with``
    blocks (not ``if TYPE_CHECKING:``, not function or class bodies)."""
    for node in body:
        yield node
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else getattr(test, "attr", None)
            if name != "TYPE_CHECKING":
                yield from _module_level(node.body)
            yield from _module_level(node.orelse)
        elif isinstance(node, ast.Try):
            for block in (node.body, *(h.body for h in node.handlers), node.orelse):
                yield from _module_level(block)
            yield from _module_level(node.finalbody)
        elif isinstance(node, ast.With):
            yield from _module_level(node.body)


def _is_kernel(node: ast.AST) -> bool:
    if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
        return False
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = getattr(target, "id", None) or getattr(target, "attr", None)
        if name in NUMBA_DECORATORS:
            return True
    return False


def _read(path: Path, root: Path) -> tuple[list[Path], bool]:
    """The modules of ``root``'s package ``path`` imports at module level, and whether it has
    kernels. A file that does not parse (being edited) imports nothing and has no kernels: its
    entries are dropped, and parsed again once its content changes."""
    try:
        tree = ast.parse(path.read_bytes(), filename=str(path))
    except (SyntaxError, ValueError):
        return [], False
    package = list(path.relative_to(root.parent).parent.parts)  # for relative imports
    found: set[Path] = set()
    for node in _module_level(tree.body):
        if isinstance(node, ast.Import):
            hits = [_module_file(root, alias.name.split(".")) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            parts = base + (node.module.split(".") if node.module else [])
            module = _module_file(root, parts)
            if module is not None and module.name == "__init__.py":
                # from a package: its submodules, else names its __init__ defines
                hits = [_module_file(root, [*parts, a.name]) or module for a in node.names]
            else:
                hits = [module]
        else:
            continue
        found.update(h for h in hits if h is not None and _key(h, root) != _SELF)
    found.discard(path)
    return sorted(found), any(_is_kernel(node) for node in ast.walk(tree))


def module_imports(path: Path) -> list[Path]:
    """The modules of ``path``'s top package that ``path`` imports at module level (the rule of
    the module doc), sorted."""
    path = Path(path).resolve()
    return _read(path, _top_package(path.parent))[0]


def _scan(directory: Path, root: Path) -> tuple[dict[str, list[Path]], list[Path]]:
    """Every kernel module of ``directory`` (file stem -> its dependencies, itself included,
    sorted), and every file read: the directory's modules and all dependencies."""
    read: dict[Path, tuple[list[Path], bool]] = {}

    def visit(path: Path) -> tuple[list[Path], bool]:
        if path not in read:
            read[path] = _read(path, root)
        return read[path]

    kernels: dict[str, list[Path]] = {}
    for path in _modules(directory, root):
        if not visit(path)[1]:
            continue
        seen, todo = {path}, [path]
        while todo:
            for dep in visit(todo.pop())[0]:
                if dep not in seen:
                    seen.add(dep)
                    todo.append(dep)
        kernels[path.stem] = sorted(seen)
    return kernels, sorted(read)


def kernel_dependencies(directory: Path) -> dict[str, list[Path]]:
    """Every kernel module of ``directory`` (by file stem) and its dependencies: its own file
    and the package modules it imports at module level, transitively (the module doc)."""
    directory = Path(directory).resolve()
    return _scan(directory, _top_package(directory))[0]


def kernel_cache_dir(directory: Path) -> Path | None:
    """The directory numba caches the kernels of ``directory``'s modules in, or None when it
    has no writable one: numba's own choice for a function defined in the directory's first
    module (``NUMBA_CACHE_DIR``, ``__pycache__``, the user-wide cache; numba creates it)."""
    sources = sorted(Path(directory).glob("*.py"))
    if not sources:
        return None
    try:
        from numba.core.caching import FunctionCache

        namespace: dict[str, object] = {}
        exec(compile("def probe():\n    pass\n", str(sources[0]), "exec"), namespace)
        return Path(FunctionCache(namespace["probe"]).cache_path)
    except (ImportError, AttributeError, RuntimeError, OSError):  # RuntimeError: none writable
        return None


def numba_cache_dir(directory: Path) -> Path | None:
    """The directory numba caches the kernels of ``directory``'s modules in, found by numba's
    rule without importing numba (:func:`kernel_cache_dir` asks numba): ``NUMBA_CACHE_DIR``
    (numba's setting once numba is imported), else ``__pycache__`` beside the sources when it
    can be written, else numba's user-wide cache (Linux and macOS). None when none can be
    written. The directory may not exist yet (numba creates it)."""
    directory = Path(os.path.abspath(directory))  # numba's paths: absolute, links not resolved
    config = sys.modules.get("numba.core.config")
    root = getattr(config, "CACHE_DIR", None) if config else os.environ.get("NUMBA_CACHE_DIR")
    hashed = f"{directory.name}_{hashlib.sha1(str(directory).encode()).hexdigest()}"
    if root:
        return Path(root) / hashed if _writable(Path(root)) else None
    if _writable(directory / "__pycache__"):
        return directory / "__pycache__"
    if sys.platform == "darwin":
        user = Path.home() / "Library" / "Caches"
    elif sys.platform.startswith("win"):
        return None
    else:
        user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return user / "numba" / hashed if _writable(user) else None


def _writable(path: Path) -> bool:
    """Whether ``path`` can be written, or created with its missing parents."""
    while not path.exists():
        if path.parent == path:
            return False
        path = path.parent
    return path.is_dir() and os.access(path, os.W_OK | os.X_OK)


class _IndexReader(pickle.Unpickler):
    """Reads numba's cache index without numba: each numba type becomes its name, nothing else
    of numba is built (no class of numba or any other module is ever called)."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) == ("numba.core.types.abstract", "_type_reconstructor"):
            return lambda _rebuild, _args, state: (state or {}).get("name")
        if module.startswith("numba.") or (module, name) in _HARMLESS:
            return lambda *args, **kw: None
        raise pickle.UnpicklingError(f"{module}.{name} in a numba index")


_HARMLESS = {("copyreg", "_reconstructor"), ("builtins", "object")}


def cached_signatures(cache: Path, source: Path, function: str) -> list[tuple[Any, ...]]:
    """The signatures (tuples of argument type names: ``"float64"``, ``"array(float64, 1d,
    C)"``, ``"none"``...) numba's cache directory ``cache`` holds for the kernel ``function``
    (its qualified name) of the module file ``source``: those of an index written by this numba
    for the file's current content, whose data file is there. Read without importing numba;
    an index it cannot read holds none."""
    try:
        from importlib.metadata import version

        numba_version = version("numba")
        content = source.read_bytes()
    except (OSError, ImportError, ValueError):
        return []
    digest = hashlib.sha256(content).digest()
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    found = []
    for index in sorted(cache.glob(f"{source.stem}.{function}-*.{tag}.nbi")):
        try:
            with open(index, "rb") as f:
                if pickle.load(f) != numba_version:
                    continue
                stamp, overloads = _IndexReader(f).load()
        except Exception:  # noqa: BLE001 - any unreadable index holds nothing
            continue
        if stamp != digest:
            continue
        found += [key[0] for key, data in overloads.items() if (cache / data).is_file()]
    return found


def stamp_current(directory: Path, cache: Path) -> bool:
    """Whether the stamp in ``cache`` was written for the current sources of ``directory``:
    :func:`drop_stale_kernels` would drop nothing (a read and a hash per file, no parsing)."""
    directory = Path(directory).resolve()
    return _current(directory, _top_package(directory), _read_stamp(Path(cache)))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _read_stamp(cache: Path) -> dict[str, dict[str, str]]:
    """The stamp's ``files`` and ``kernels`` (empty when missing, unreadable or of another
    layout)."""
    try:
        stamp = json.loads((cache / STAMP).read_bytes())
        if stamp["format"] == FORMAT:
            return {"files": dict(stamp["files"]), "kernels": dict(stamp["kernels"])}
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return {"files": {}, "kernels": {}}


def _current(directory: Path, root: Path, stamp: dict[str, dict[str, str]]) -> bool:
    """True when ``stamp`` was written for these sources (see the module doc; no parsing)."""
    files = stamp["files"]
    names = {_key(p, root) for p in _modules(directory, root)}
    prefix = _key(directory, root) + "/"
    recorded = {k for k in files if k.startswith(prefix) and "/" not in k[len(prefix) :]}
    if not files or names != recorded:
        return False
    try:
        return all(_sha256(root.parent / key) == digest for key, digest in files.items())
    except OSError:  # a recorded file is gone
        return False


@contextlib.contextmanager
def _locked(cache: Path) -> Iterator[None]:
    """An exclusive lock on the cache directory, held until the block ends (waits for it)."""
    fd = os.open(cache / LOCK, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - no flock (Windows): no lock
            yield
            return
        fcntl.flock(fd, fcntl.LOCK_EX)  # released when fd closes
        yield
    finally:
        os.close(fd)


def _refresh(directory: Path, root: Path, cache: Path, done: Dropped) -> None:
    """Under the lock: drop the entries of modules whose dependency hash changed, write the new
    stamp."""
    old = _read_stamp(cache)
    if _current(directory, root, old):
        return  # another process did it while this one waited for the lock
    kernels, files = _scan(directory, root)
    digests = {_key(p, root): _sha256(p) for p in files}
    hashes: dict[str, str] = {}
    for module, deps in kernels.items():
        h = hashlib.sha256()
        for dep in deps:
            h.update(f"{_key(dep, root)}\0{digests[_key(dep, root)]}\n".encode())
        hashes[module] = h.hexdigest()
    kept = {m for m, h in hashes.items() if old["kernels"].get(m) == h}
    dropped = set()
    for name in os.listdir(cache):
        module = name.split(".", 1)[0]
        if name.endswith(CACHE_SUFFIXES) and module not in kept:
            (cache / name).unlink(missing_ok=True)
            dropped.add(module)
            done.files += 1
    done.modules = sorted(dropped)
    stamp = {"format": FORMAT, "files": digests, "kernels": hashes}
    tmp = cache / f"{STAMP}.tmp.{os.getpid()}"
    try:
        tmp.write_text(json.dumps(stamp, indent=1, sort_keys=True))
        os.replace(tmp, cache / STAMP)
    finally:
        tmp.unlink(missing_ok=True)


def drop_stale_kernels(directory: Path, cache_dir: Path | None = None) -> Dropped:
    """Drop numba's cache entries of ``directory``'s kernel modules whose dependencies changed
    since the cache directory's stamp was written (the module doc), and write the new stamp.
    ``cache_dir``: the cache directory (default: numba's, :func:`kernel_cache_dir`). Does
    nothing where it is missing or read-only; raises nothing for either."""
    start = time.perf_counter()
    directory = Path(directory).resolve()
    root = _top_package(directory)
    cache = kernel_cache_dir(directory) if cache_dir is None else Path(cache_dir)
    done = Dropped(cache_dir=cache)
    if cache is not None and cache.is_dir() and os.access(cache, os.W_OK):
        try:
            if not _current(directory, root, _read_stamp(cache)):
                with _locked(cache):
                    _refresh(directory, root, cache, done)
            done.checked = True
        except OSError:
            pass  # the directory vanished or turned read-only meanwhile: numba copes alone
    done.seconds = time.perf_counter() - start
    return done


def _blas_present() -> None:
    """numba's BLAS probe (``numba.np.linalg.ensure_blas``) answered without importing scipy:
    raises ImportError unless scipy's ``linalg/cython_blas`` extension module is installed."""
    spec = importlib.util.find_spec("scipy")  # imports nothing of scipy
    for folder in (spec.submodule_search_locations or []) if spec is not None else []:
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            if Path(folder, "linalg", f"cython_blas{suffix}").is_file():
                return
    raise ImportError("scipy.linalg.cython_blas is not installed")


def _import_arraymath() -> None:
    """Import ``numba.np.arraymath`` with its BLAS probe answered by :func:`_blas_present` (the
    module doc); numba's own probe is back in place afterwards."""
    if "numba.np.arraymath" in sys.modules:
        return
    try:
        from numba.np import linalg

        probe = linalg.ensure_blas
    except (ImportError, AttributeError):  # another numba: its own import, later
        return
    linalg.ensure_blas = _blas_present
    try:
        from numba.np import arraymath
    finally:
        linalg.ensure_blas = probe
    if getattr(arraymath, "ensure_blas", None) is _blas_present:
        arraymath.ensure_blas = probe


@functools.cache
def _lean_cache_class() -> type | None:
    """numba's per-function cache with a load that skips the target context's refresh (the
    module doc); None when this numba's cache lacks what it relies on."""
    try:
        from numba.core.caching import FunctionCache
        from numba.core.runtime import rtsys
    except ImportError:
        return None
    needed = ("load_overload", "_load_overload", "_guard_against_spurious_io_errors")
    if not all(hasattr(FunctionCache, name) for name in needed):
        return None

    class LeanFunctionCache(FunctionCache):  # type: ignore[misc]
        def load_overload(self, sig: Any, target_context: Any) -> Any:
            rtsys.initialize(target_context)  # what the refresh does first: kernels need NRT
            _import_arraymath()  # numba holds its compiler lock here: no probe runs meanwhile
            with self._guard_against_spurious_io_errors(), _lean_libraries(target_context):
                return self._load_overload(sig, target_context)

    return LeanFunctionCache


@contextlib.contextmanager
def _lean_libraries(target_context: Any) -> Iterator[None]:
    """While numba loads a kernel (under its compiler lock), its code library is
    :mod:`._lean_library`'s: the linking bitcode is parsed when a later kernel links it."""
    from ._lean_library import lean_library_class

    codegen = target_context.codegen()
    lean = lean_library_class(type(codegen)._library_class)
    if lean is None or "_library_class" in vars(codegen):
        yield
        return
    codegen._library_class = lean
    try:
        yield
    finally:
        del codegen._library_class


def load_lean(*kernels: Any) -> None:
    """Let ``kernels`` (numba dispatchers with ``cache=True``) load from numba's cache without
    refreshing numba's whole target context first (the module doc). The machine code loaded is
    numba's cache entry either way. Does nothing for a kernel without numba's own cache, or
    when this numba's cache class lacks what the lean load relies on."""
    lean = _lean_cache_class()
    if lean is None:
        return
    for kernel in kernels:
        cache = getattr(kernel, "_cache", None)
        if type(cache) is lean.__base__:
            cache.__class__ = lean


#: what the check of ``bowlrec/core`` did in this process (:func:`check_core`); None before it
LAST: Dropped | None = None


def check_core() -> Dropped:
    """The check of ``bowlrec/core`` (:func:`drop_stale_kernels`), once per process: ``vec``
    runs it when imported, before any kernel loads. Returns what it did (:data:`LAST`)."""
    global LAST
    if LAST is None:
        LAST = drop_stale_kernels(Path(__file__).parent)
    return LAST
