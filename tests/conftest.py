"""Shared pytest configuration: test tiers, the guard of the default tier, the kernel warm-up,
the isolated environment of every test, and the server and process fixtures.

Tiers (docs/architecture.md, "Tests"). A test's tier is its first marker in the order ``slow``,
``browser``, ``fault``, ``process``; a test with none of them is in the ``default`` tier, which
is in-process only (no subprocess, no socket bound, no process pool). ``--tier`` selects tiers
(``--tier process``, ``--tier fault,browser``, ``--tier all`` for every tier but ``slow``);
without it, ``-m EXPR`` alone decides, and without either only the default tier runs (the
README's ``python -m pytest -q``). Test IDs named on the command line (``path::name``) run
whatever their tier. Tests using the fixtures of :data:`FIXTURE_TIERS` (real servers, real
``bowlrec`` processes, Chromium) get that fixture's marker at collection.

The guard: while a test without a ``process``, ``fault`` or ``browser`` marker sets up or runs,
starting a subprocess, forking, starting a multiprocessing process (pools, fork servers,
resource trackers) or binding/listening on a socket raises :class:`TierViolation`, and the test
fails even if the code under test caught that exception.

xdist: without ``-n`` on the command line the tests run on ``-n auto`` workers (``-n 0`` or
``-p no:xdist`` run them in this process). The kernel warm-up runs once, in this (the
controller) process before the workers start, so the workers load every kernel from numba's
on-disk cache; its time is printed when it finishes and in the terminal summary.
``--no-kernel-warm-up`` skips it (then the first test that simulates pays the compile).

Helper modules of the tests are the package ``tests/helpers`` (``from helpers.servers import
...``) and the developer scripts in ``tools/`` import as ``tools``: ``pythonpath = ["tests",
"."]`` in pyproject.toml. Shared reference deliveries and the paper's RK4 scheme come from
:mod:`bowlrec.testing`.
"""

from __future__ import annotations

import functools
import multiprocessing.process
import multiprocessing.util
import os
import shutil
import socket
import subprocess
import tempfile
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from helpers.processes import home_env
from helpers.processes import run_bowlrec as _run_bowlrec
from helpers.servers import AppServer, Server, start_server

#: the tiers besides the default one, with what they hold
MARKERS = {
    "process": "real processes: bowlrec CLI subprocesses, servers on loopback, README blocks, "
    "Dask clusters, process pools",
    "fault": "fault campaigns with real kills (SIGKILL, orphans), hostile-input sweeps, disk full",
    "browser": "the web pages in Chromium (Playwright)",
    "slow": "heavy variants, opt-in only (--tier slow or -m slow)",
}
#: a test's tier: the first of its markers in this order, else "default"
ORDER = ("slow", "browser", "fault", "process")
TIERS = ("default", "process", "fault", "browser", "slow")
#: what ``--tier all`` selects (``slow`` is only ever run when named)
ALL = ("default", "process", "fault", "browser")
#: the markers that let a test start processes and bind sockets
ALLOWED = frozenset(("process", "fault", "browser"))
#: programs libraries run once to probe the machine, allowed in the default tier too
#: (``platform.platform()`` runs ``uname -p``; matplotlib's font cache runs ``fc-list``)
PROBES = frozenset(("uname", "fc-list"))
#: fixtures that put the tests using them (directly or through other fixtures) in a tier; a test
#: module may add its own fixtures in a dict of the same name
FIXTURE_TIERS = {
    "serve": "process",
    "module_serve": "process",
    "run_bowlrec": "process",
}

if TYPE_CHECKING:
    from bowlrec.core.warm import WarmUp

#: what the warm-up measured: "seconds", "compiled" and "loaded" (entries of numba's cache)
WARM_UP: dict[str, float] = {}
#: per tier: tests selected and deselected (this process, or summed over the xdist workers)
SELECTED: Counter[str] = Counter()
DESELECTED: Counter[str] = Counter()
#: kernels compiled by the warm-up, and after it by the test processes (what the warm-up
#: misses: each xdist worker compiles it again), by name
COMPILED_IN_WARM_UP: Counter[str] = Counter()
COMPILED_IN_TESTS: Counter[str] = Counter()

VIOLATIONS = pytest.StashKey[list[str]]()


class TierViolation(Exception):
    """A test of the default tier started a process or bound a socket."""


# -- options, xdist -------------------------------------------------------------------------------


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("bowlrec", "bowlrec's test tiers")
    group.addoption(
        "--tier",
        action="append",
        default=None,
        metavar="TIER[,TIER...]",
        help="run the tests of these tiers: default, process, fault, browser, slow, or all (every "
        "tier but slow). Default: the default tier (or what -m selects, when given)",
    )
    group.addoption(
        "--no-kernel-warm-up",
        action="store_true",
        help="do not compile or load bowlrec's numba kernels before the first test",
    )


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config: pytest.Config) -> None:
    """xdist (when loaded): ``-n auto`` unless ``-n``/``--numprocesses`` was given, and unless
    ``--dist`` was given, ``worksteal`` for the default tier (short tests, rebalanced as workers
    finish) and ``loadfile`` with any other tier (a module's server, pool or sweep is started by
    one worker, not by each)."""
    option = config.option
    if not hasattr(option, "numprocesses") or option.collectonly:
        return
    if _is_worker(config) or "PYTEST_XDIST_WORKER" in os.environ:
        return  # a worker (xdist resets its -n to None), or a pytest a worker started
    if option.numprocesses is None:
        option.numprocesses = "auto"
    if option.dist == "no" and option.numprocesses != 0:
        option.dist = "worksteal" if _selected_tiers(config) == ("default",) else "loadfile"


def _selected_tiers(config: pytest.Config) -> tuple[str, ...]:
    """The tiers ``--tier`` names; without it: every tier when ``-m`` is given (it alone
    selects), else the default tier."""
    names = [n.strip() for arg in config.getoption("tier") or () for n in arg.split(",")]
    if not names:
        return TIERS if config.option.markexpr else ("default",)
    out: list[str] = []
    for name in names:
        if name == "all":
            out += ALL
        elif name in TIERS:
            out.append(name)
        else:
            raise pytest.UsageError(f"--tier {name}: not a tier (one of {', '.join(TIERS)}, all)")
    return tuple(dict.fromkeys(out))


def _is_worker(config: pytest.Config) -> bool:
    return hasattr(config, "workerinput")


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node: Any) -> None:
    """xdist: the workers select what the controller selected."""
    node.workerinput["bowlrec_tiers"] = list(node.config.stash[_TIERS_KEY])


_TIERS_KEY = pytest.StashKey[tuple[str, ...]]()
_RUN_DIR = pytest.StashKey[Path]()


def pytest_configure(config: pytest.Config) -> None:
    for name, text in MARKERS.items():
        config.addinivalue_line("markers", f"{name}: {text}")
    if _is_worker(config):
        config.stash[_TIERS_KEY] = tuple(config.workerinput["bowlrec_tiers"])  # type: ignore[attr-defined]
    else:
        config.stash[_TIERS_KEY] = _selected_tiers(config)
        _run_wide_environment(config)
    _install_guard()


def _run_wide_environment(config: pytest.Config) -> None:
    """A temporary HOME (and XDG directories) for this run, inherited by the xdist workers and
    whatever starts before a test's own (module-scoped fixtures); the viewer's file cache and
    matplotlib's font cache are shared by the run's processes (both lock their writes)."""
    run = Path(tempfile.mkdtemp(prefix="bowlrec-tests-"))
    config.stash[_RUN_DIR] = run
    real_home = Path.home()
    browsers = real_home / ".cache" / "ms-playwright"
    if "PLAYWRIGHT_BROWSERS_PATH" not in os.environ and browsers.is_dir():
        os.environ["PLAYWRIGHT_BROWSERS_PATH"] = str(browsers)  # installed by `playwright install`
    os.environ.update(home_env(run / "home"))
    os.environ["BOWLREC_CACHE_DIR"] = str(run / "cache")
    os.environ["MPLCONFIGDIR"] = str(run / "matplotlib")
    os.environ["BOWLREC_ARCHIVE"] = str(run / "archive")
    for var in ("BOWLREC_CONFIG", "BOWLREC_TOKEN", "BOWLREC_SCHEDULER"):
        os.environ.pop(var, None)


def pytest_unconfigure(config: pytest.Config) -> None:
    run = config.stash.get(_RUN_DIR, None)
    if run is not None:
        shutil.rmtree(run, ignore_errors=True)


# -- the kernel warm-up ---------------------------------------------------------------------------


def _compiled() -> Counter[str]:
    """Compilations of this process (numba cache misses), by kernel."""
    from bowlrec.core.warm import kernels

    out: Counter[str] = Counter()
    for d in kernels():
        misses = sum(d.stats.cache_misses.values())
        if misses:
            out[f"{d.__module__.removeprefix('bowlrec.')}.{d.__name__}"] += misses
    return out


def warm_up_kernels(jobs: int = 1) -> WarmUp:
    """Run every compiled kernel once (:func:`bowlrec.testing.warm.warm_up_all`: the integrator
    in each recording mode and observing, the closed form, the many-delivery batch kernel serial
    and parallel, and the paper's RK4 scheme when scipy is installed); ``jobs`` > 1: in that many
    fresh processes at once, which compile a cold cache in about 0.8 of the time on 2 cores
    (``benchmarks/results/kernel_cache.md``) and load a warm one in the same ~2 s as one."""
    from bowlrec.testing.warm import warm_up_all

    return warm_up_all(jobs)


def _report(config: pytest.Config, line: str) -> None:
    """Write ``line`` to the terminal now, whatever the capture and verbosity."""
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter is None:
        return
    capture = config.pluginmanager.get_plugin("capturemanager")
    if capture is None:
        reporter.write_line(line)
        return
    with capture.global_and_fixture_disabled():
        reporter.write_line(line)


def _summary() -> str:
    return (
        f"kernel warm-up: {WARM_UP['seconds']:.1f} s before the first test "
        f"({WARM_UP['compiled']:.0f} kernels compiled, {WARM_UP['loaded']:.0f} loaded from "
        "numba's cache)"
    )


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """Compile or load every kernel once, in this process, before any worker starts."""
    config = session.config
    if _is_worker(config) or config.option.collectonly:
        return
    if config.getoption("no_kernel_warm_up"):
        return
    done = warm_up_kernels(jobs=min(2, os.cpu_count() or 1))
    WARM_UP.update(seconds=done.seconds, compiled=done.compiled, loaded=done.loaded)
    COMPILED_IN_WARM_UP.update(_compiled())
    _report(config, _summary())


# -- selection ------------------------------------------------------------------------------------


def tier_of(item: pytest.Item) -> str:
    names = {mark.name for mark in item.iter_markers()}
    return next((tier for tier in ORDER if tier in names), "default")


def _named_ids(config: pytest.Config) -> set[str]:
    """The test IDs (``path::name...``) named on the command line, as node IDs."""
    out = set()
    root = config.rootpath
    for arg in config.args:
        if "::" not in arg:
            continue
        path, _, rest = arg.partition("::")
        full = (config.invocation_params.dir / path).resolve()
        try:
            rel = full.relative_to(root).as_posix()
        except ValueError:
            continue
        out.add(f"{rel}::{rest}")
    return out


def _named(nodeid: str, named: set[str]) -> bool:
    return any(nodeid == n or nodeid.startswith((f"{n}[", f"{n}::")) for n in named)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Marks the users of the :data:`FIXTURE_TIERS` fixtures, then keeps the selected tiers'
    tests (before ``-m`` and ``-k`` filter further)."""
    for item in items:
        module = getattr(item, "module", None)
        by_fixture = {**FIXTURE_TIERS, **getattr(module, "FIXTURE_TIERS", {})}
        for fixture in getattr(item, "fixturenames", ()):
            tier = by_fixture.get(fixture)
            if tier is not None:
                item.add_marker(tier)
    tiers = config.stash[_TIERS_KEY]
    named = _named_ids(config)
    keep, drop = [], []
    for item in items:
        tier = tier_of(item)
        if tier in tiers or _named(item.nodeid, named):
            keep.append(item)
            SELECTED[tier] += 1
        else:
            drop.append(item)
            DESELECTED[tier] += 1
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep


# -- the guard ------------------------------------------------------------------------------------

#: the item of the default tier whose setup or call is running (empty: nothing is guarded)
_GUARDED: list[pytest.Item] = []


def _violation(what: str) -> None:
    if not _GUARDED:
        return
    item = _GUARDED[-1]
    message = (
        f"{item.nodeid} {what}, but it is in the default tier, which is in-process only: "
        "mark it @pytest.mark.process (a subprocess, a server, a process pool), "
        "@pytest.mark.fault (kills, hostile sweeps) or @pytest.mark.browser, or use the "
        "in-process equivalent (typer's CliRunner, helpers.servers.AppServer). "
        "docs/architecture.md, Tests"
    )
    item.stash.setdefault(VIOLATIONS, []).append(message)
    raise TierViolation(message)


def _is_path(args: Any) -> bool:
    return isinstance(args, (str, bytes, os.PathLike))


def _command(args: Any) -> str:
    if _is_path(args):
        return os.fsdecode(args)
    return " ".join(os.fsdecode(a) for a in args)[:200]


_INSTALLED: list[bool] = []


def _install_guard() -> None:
    """Wrap what starts processes and binds sockets with a check of :data:`_GUARDED` (once per
    process; the wrappers cost a list lookup when no default-tier test runs)."""
    if _INSTALLED:
        return
    _INSTALLED.append(True)

    def wrap(owner: Any, name: str, what: Callable[..., str]) -> None:
        original = getattr(owner, name, None)
        if original is None:
            return

        @functools.wraps(original)
        def guarded(*args: Any, **kw: Any) -> Any:
            if _GUARDED and (found := what(*args, **kw)):
                _violation(found)
            return original(*args, **kw)

        setattr(owner, name, guarded)

    def popen(self: Any, args: Any, *a: Any, **kw: Any) -> str:
        program = os.path.basename(os.fsdecode(args if _is_path(args) else args[0]))
        return "" if program in PROBES else f"starts a subprocess ({_command(args)})"

    wrap(subprocess.Popen, "_execute_child", popen)
    for name in ("fork", "forkpty", "posix_spawn", "posix_spawnp", "system"):
        wrap(os, name, lambda *a, _n=name, **kw: f"calls os.{_n}()")
    wrap(
        multiprocessing.process.BaseProcess,
        "start",
        lambda self: f"starts a multiprocessing process ({type(self).__name__})",
    )
    wrap(multiprocessing.util, "spawnv_passfds", lambda *a, **kw: "starts a multiprocessing helper")
    wrap(socket.socket, "bind", lambda self, address: f"binds a socket to {address!r}")
    wrap(socket.socket, "listen", lambda self, *a: "listens on a socket")


def _guarded(item: pytest.Item) -> bool:
    return ALLOWED.isdisjoint(mark.name for mark in item.iter_markers())


def _phase(item: pytest.Item) -> Iterator[None]:
    """A setup or call of ``item``, guarded when ``item`` has none of the :data:`ALLOWED`
    markers; a :class:`TierViolation` the code under test caught still fails the phase."""
    guard = _guarded(item)
    if guard:
        _GUARDED.append(item)
    try:
        result = yield
    finally:
        if guard:
            _GUARDED.remove(item)
        found = item.stash.get(VIOLATIONS, [])
        item.stash[VIOLATIONS] = []
    if found:
        raise TierViolation(found[0])
    return result


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item: pytest.Item) -> Iterator[None]:
    return (yield from _phase(item))


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    return (yield from _phase(item))


# -- reporting ------------------------------------------------------------------------------------


def pytest_sessionfinish(session: pytest.Session) -> None:
    config = session.config
    compiled = _compiled() - COMPILED_IN_WARM_UP
    if _is_worker(config):
        out = config.workeroutput  # type: ignore[attr-defined]
        out["bowlrec_selected"] = dict(SELECTED)
        out["bowlrec_deselected"] = dict(DESELECTED)
        out["bowlrec_compiled"] = dict(compiled)
    else:
        COMPILED_IN_TESTS.update(compiled)


_SEEN_WORKERS: set[str] = set()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: object) -> None:
    """xdist: what a worker selected (each selects the same tests) and compiled."""
    out = getattr(node, "workeroutput", None) or {}
    if "bowlrec_selected" not in out:
        return
    if not _SEEN_WORKERS:
        SELECTED.update(out["bowlrec_selected"])
        DESELECTED.update(out["bowlrec_deselected"])
    _SEEN_WORKERS.add(node.gateway.id)
    COMPILED_IN_TESTS.update(out.get("bowlrec_compiled", {}))


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    if WARM_UP:
        terminalreporter.write_line(_summary())
    if COMPILED_IN_TESTS:
        per = ", ".join(f"{name} {n}" for name, n in sorted(COMPILED_IN_TESTS.items()))
        terminalreporter.write_line(
            f"kernels compiled during the tests (missed by the warm-up; every worker compiles "
            f"its own): {per}"
        )
    if SELECTED or DESELECTED:
        ran = ", ".join(f"{t} {SELECTED[t]}" for t in TIERS if SELECTED[t])
        line = f"tests per tier: selected {ran or 'none'}"
        if config.option.markexpr or config.option.keyword:
            line += " (before -m/-k)"
        skipped = ", ".join(f"{t} {DESELECTED[t]}" for t in TIERS if DESELECTED[t])
        if skipped:
            line += f"; not selected: {skipped} (--tier NAME or --tier all to run them)"
        terminalreporter.write_line(line)


# -- the environment of every test ----------------------------------------------------------------


@pytest.fixture(autouse=True)
def _isolated_environment(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A temporary HOME, XDG config/cache/data/state directories and archive of its own for
    every test (tests run side by side under xdist); no token, config file or Dask scheduler
    from the developer's shell. Commands that archive by default write to ``$BOWLREC_ARCHIVE``,
    which does not exist yet."""
    base = tmp_path_factory.mktemp("env")
    for var, value in home_env(base / "home").items():
        monkeypatch.setenv(var, value)
    monkeypatch.setenv("BOWLREC_ARCHIVE", str(base / "archive" / "a"))
    for var in ("BOWLREC_CONFIG", "BOWLREC_TOKEN", "BOWLREC_SCHEDULER"):
        monkeypatch.delenv(var, raising=False)


# -- servers and processes ------------------------------------------------------------------------


def _server_factory(
    factory: pytest.TempPathFactory,
) -> tuple[Callable[..., Server], list[Server]]:
    started: list[Server] = []

    def start(archive: Path | None = None, token: str | None = None, *extra: str, **kw: Any):
        if archive is None:
            archive = factory.mktemp("serve") / "archive"
        server = start_server(archive, token, *extra, **kw)
        started.append(server)
        return server

    return start, started


@pytest.fixture
def serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[..., Server]]:
    """``serve(archive=None, token=None, *extra, **kw)``: a ``bowlrec serve`` child process on
    a free loopback port (:func:`helpers.servers.start_server`; a new archive by default),
    stopped after the test. Its users are in the ``process`` tier."""
    start, started = _server_factory(tmp_path_factory)
    yield start
    for server in started:
        server.stop()


@pytest.fixture(scope="module")
def module_serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[..., Server]]:
    """:func:`serve` for a module's shared server (stopped after the module)."""
    start, started = _server_factory(tmp_path_factory)
    yield start
    for server in started:
        server.stop()


def _app_factory(factory: pytest.TempPathFactory) -> tuple[Callable[..., AppServer], list[Any]]:
    started: list[AppServer] = []

    def start(archive: Path | None = None, token: str | None = None, **options: Any) -> AppServer:
        if archive is None:
            archive = factory.mktemp("app") / "archive"
        raise_errors = options.pop("raise_server_exceptions", True)
        server = AppServer(archive, token, options, raise_errors)
        started.append(server)
        return server

    return start, started


@pytest.fixture
def app_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[..., AppServer]]:
    """``app_server(archive=None, token=None, **create_app_options)``: the service in process
    (:class:`helpers.servers.AppServer`), stopped after the test. Default tier."""
    start, started = _app_factory(tmp_path_factory)
    yield start
    for server in started:
        server.stop()


@pytest.fixture(scope="module")
def module_app_server(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[Callable[..., AppServer]]:
    """:func:`app_server` for a module's shared app (stopped after the module)."""
    start, started = _app_factory(tmp_path_factory)
    yield start
    for server in started:
        server.stop()


@pytest.fixture
def run_bowlrec() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``run_bowlrec(*args, env=None, timeout=600, **run_kw)``: ``bowlrec ARGS`` in a real
    process (:func:`helpers.processes.run_bowlrec`). Its users are in the ``process`` tier."""
    return _run_bowlrec
