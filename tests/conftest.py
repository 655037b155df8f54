"""Shared pytest configuration.

Helper modules of the tests (``scene_builders``, ``hostile_inputs``, ``test_service``...) import
as top-level modules, and the developer scripts in ``tools/`` as ``tools``: ``pythonpath =
["tests", "."]`` in pyproject.toml. Shared reference deliveries
and the paper's RK4 scheme come from :mod:`bowlrec.testing`.

Kernel warm-up: before the first test, :func:`_kernels_warmed_up` runs every compiled kernel
once (from numba's on-disk cache, or compiling it when the cache is missing or stale: about a
minute, benchmarks/results/core_layout.md, first compile), so no test's time includes the
compile and child processes started by tests find the cache ready. Its time is printed when it
finishes and again in the terminal summary.
``--no-kernel-warm-up`` skips it (then the first test that simulates pays the compile).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from typing import Any

import pytest

#: what the warm-up measured: "seconds", "compiled" and "loaded" (entries of numba's cache)
WARM_UP: dict[str, float] = {}


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--no-kernel-warm-up",
        action="store_true",
        help="do not compile or load bowlrec's numba kernels before the first test",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "slow: heavy stress variants (run in benchmarks)")


def _dispatchers() -> list[Any]:
    """Every numba kernel of the loaded bowlrec modules."""
    from numba.core.registry import CPUDispatcher

    return [
        obj
        for name, module in list(sys.modules.items())
        if name.startswith("bowlrec.") and module is not None
        for obj in vars(module).values()
        if isinstance(obj, CPUDispatcher) and obj.__module__ == name
    ]


def warm_up_kernels() -> None:
    """Run every compiled kernel once: the integrator in each recording mode (summary, every
    step with the equation terms, fixed rate), the closed form, the many-delivery batch kernel
    serial and parallel, and the paper's RK4 scheme (when scipy is installed)."""
    import dataclasses

    from bowlrec.core.batch import pack_plans, run_batch
    from bowlrec.core.codes import RECORD_RATE, RECORD_STEPS
    from bowlrec.core.solver import solve, use_closed_form
    from bowlrec.testing.scenes import table3_plans

    plans = dict(table3_plans())  # summary only
    uniform = plans["case01"]  # uniform ball: the closed form
    offset = plans["case16"]  # offset ball on the typical pattern: the integrator
    assert use_closed_form(uniform) and not use_closed_form(offset)
    solve(uniform)
    solve(offset)
    solve(dataclasses.replace(offset, record_mode=RECORD_STEPS, record_terms=True))
    solve(dataclasses.replace(offset, record_mode=RECORD_RATE, record_dt_s=0.01))
    packed = pack_plans([uniform, offset])
    run_batch(packed, parallel=False)
    run_batch(packed, parallel=True)
    try:
        import scipy  # noqa: F401  (numba's np.linalg in the RK4 kernel)
    except ImportError:
        return
    from bowlrec.testing.rk4 import paper_scheme

    paper_scheme(offset, dt=1e-2)


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


@pytest.fixture(scope="session", autouse=True)
def _kernels_warmed_up(pytestconfig: pytest.Config) -> Iterator[None]:
    """Compile or load every compiled kernel once, before the first test (see the module doc)."""
    if pytestconfig.getoption("no_kernel_warm_up"):
        yield
        return
    start = time.perf_counter()
    warm_up_kernels()
    WARM_UP["seconds"] = time.perf_counter() - start
    stats = [d.stats for d in _dispatchers()]
    WARM_UP["compiled"] = sum(sum(s.cache_misses.values()) for s in stats)
    WARM_UP["loaded"] = sum(sum(s.cache_hits.values()) for s in stats)
    _report(pytestconfig, _summary())
    yield


def pytest_terminal_summary(terminalreporter: Any) -> None:
    if WARM_UP:
        terminalreporter.write_line(_summary())


@pytest.fixture(autouse=True)
def _private_archive(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Commands that archive by default write to a temporary archive, never to $HOME."""
    monkeypatch.setenv("BOWLREC_ARCHIVE", str(tmp_path_factory.mktemp("archive") / "a"))
