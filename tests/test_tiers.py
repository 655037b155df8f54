"""The test tiers of tests/conftest.py: a test's tier, the guard of the default tier and the
``--tier`` switch (docs/architecture.md, "Tests")."""

from __future__ import annotations

import multiprocessing
import os
import re
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import conftest
import pytest

TESTS = Path(__file__).resolve().parent


def _forget(request: pytest.FixtureRequest) -> None:
    """This test provoked the guard on purpose: its violations do not fail it."""
    request.node.stash[conftest.VIOLATIONS] = []


# -- the guard, from inside a default-tier test ------------------------------------------------


def test_the_default_tier_may_not_start_a_subprocess(request: pytest.FixtureRequest) -> None:
    message = r"starts a subprocess \(.*-c pass\), but it is in the default tier.*@pytest.mark"
    with pytest.raises(conftest.TierViolation, match=message):
        subprocess.run([sys.executable, "-c", "pass"], check=False)
    _forget(request)


def test_the_default_tier_may_not_bind_or_listen(request: pytest.FixtureRequest) -> None:
    with socket.socket() as s:
        with pytest.raises(conftest.TierViolation, match=r"binds a socket to \('127.0.0.1', 0\)"):
            s.bind(("127.0.0.1", 0))
        with pytest.raises(conftest.TierViolation, match="listens on a socket"):
            s.listen()
    _forget(request)


def test_the_default_tier_may_not_start_a_process_or_fork(request: pytest.FixtureRequest) -> None:
    process = multiprocessing.get_context("spawn").Process(target=print)
    with pytest.raises(conftest.TierViolation, match="starts a multiprocessing process"):
        process.start()
    with pytest.raises(conftest.TierViolation, match=r"calls os.fork\(\)"):
        os.fork()
    _forget(request)


def test_probes_of_the_machine_pass() -> None:
    """What libraries run once to learn about the machine (platform's ``uname -p``)."""
    uname = shutil.which("uname")
    if uname is None:
        pytest.skip("no uname here")
    subprocess.run([uname, "-p"], capture_output=True, check=False)


@pytest.mark.process
def test_a_process_test_may_start_processes_and_bind() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
    subprocess.run([sys.executable, "-c", "pass"], check=True)


def test_a_tier_is_the_first_marker_in_order(request: pytest.FixtureRequest) -> None:
    node = request.node
    assert conftest.tier_of(node) == "default"
    node.add_marker("process")
    assert conftest.tier_of(node) == "process"
    node.add_marker("fault")
    assert conftest.tier_of(node) == "fault"
    node.add_marker("slow")
    assert conftest.tier_of(node) == "slow"


# -- the switch and the guard, from outside: a pytest of its own --------------------------------

TIERED = """
import subprocess, sys
import pytest

def test_plain():
    pass

@pytest.mark.process
def test_process():
    subprocess.run([sys.executable, "-c", "pass"], check=True)

@pytest.mark.fault
def test_fault():
    pass

@pytest.mark.browser
def test_browser():
    pass

@pytest.mark.slow
def test_slow():
    pass

@pytest.mark.slow
@pytest.mark.fault
def test_slow_fault():
    pass

def test_uses_the_cli_process_fixture(run_bowlrec):
    pass

def test_swallows_a_violation():
    try:
        subprocess.run([sys.executable, "-c", "pass"], check=True)
    except Exception:
        pass  # code under test that catches everything: still a failure of the test
"""


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A project with this conftest and helpers, and a test of each tier."""
    root = tmp_path_factory.mktemp("tiered")
    shutil.copy(TESTS / "conftest.py", root / "conftest.py")
    shutil.copytree(TESTS / "helpers", root / "helpers", ignore=shutil.ignore_patterns("__py*"))
    (root / "test_tiered.py").write_text(TIERED)
    (root / "pytest.ini").write_text("[pytest]\npythonpath = .\naddopts = --strict-markers\n")
    return root


def _outcomes(project: Path, *args: str) -> dict[str, str]:
    """Test name -> PASSED/FAILED of a run in ``project`` with ``args``; deselected left out."""
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:xdist", "-p", "no:cacheprovider", "-rA"]
        + ["--no-kernel-warm-up", *args],
        cwd=project,
        capture_output=True,
        text=True,
        timeout=300,
    )
    found = re.findall(r"^(PASSED|FAILED|ERROR) test_tiered.py::(\w+)", out.stdout, re.M)
    assert found or "no tests ran" in out.stdout, out.stdout + out.stderr
    return {name: outcome for outcome, name in found}


@pytest.mark.process
def test_the_switch_selects_tiers_and_the_guard_fails_a_swallowed_violation(
    project: Path,
) -> None:
    default = _outcomes(project)
    assert default == {"test_plain": "PASSED", "test_swallows_a_violation": "FAILED"}
    assert _outcomes(project, "--tier", "process") == {
        "test_process": "PASSED",
        "test_uses_the_cli_process_fixture": "PASSED",  # marked by its fixture
    }
    assert set(_outcomes(project, "--tier", "fault,browser")) == {"test_fault", "test_browser"}
    assert set(_outcomes(project, "--tier", "slow")) == {"test_slow", "test_slow_fault"}
    everything = set(_outcomes(project, "--tier", "all"))
    assert everything == set(default) | {
        "test_process",
        "test_fault",
        "test_browser",
        "test_uses_the_cli_process_fixture",
    }
    assert set(_outcomes(project, "-m", "fault")) == {"test_fault", "test_slow_fault"}
    named = _outcomes(project, "test_tiered.py::test_slow", "test_tiered.py::test_process")
    assert named == {"test_slow": "PASSED", "test_process": "PASSED"}
