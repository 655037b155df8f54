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

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from bowlrec.core.warm import WarmUp

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


def warm_up_kernels() -> WarmUp:
    """Run every compiled kernel once (:func:`bowlrec.testing.warm.warm_up_all`: the integrator
    in each recording mode and observing, the closed form, the many-delivery batch kernel serial
    and parallel, and the paper's RK4 scheme when scipy is installed)."""
    from bowlrec.testing.warm import warm_up_all

    return warm_up_all()


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
    done = warm_up_kernels()
    WARM_UP.update(seconds=done.seconds, compiled=done.compiled, loaded=done.loaded)
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
