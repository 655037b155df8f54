"""Real ``bowlrec`` processes for the tests: the command line, and the child scripts of this
package (``python -m helpers.<name>``).

Every test that starts one of these is in the ``process`` tier or another tier that allows
processes (``fault``, ``browser``); the ``run_bowlrec`` fixture of tests/conftest.py marks its
users ``process`` by itself. The environment of a child is the test's (its temporary HOME,
archive, config and cache directories: tests/conftest.py) with ``BOWLREC_TOKEN`` and
``BOWLREC_SCHEDULER`` removed and this directory's parent on ``PYTHONPATH``, so that the child
scripts import ``helpers`` as the tests do.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: tests/ (on pytest's pythonpath: ``helpers`` imports from here)
TESTS = Path(__file__).resolve().parents[1]
#: the repository
ROOT = TESTS.parent

#: variables a child never inherits from the test process (a token or a Dask scheduler of the
#: developer's shell would change what the command does)
UNSET = ("BOWLREC_TOKEN", "BOWLREC_SCHEDULER")


def child_env(env: Mapping[str, str] | None = None, **overrides: str | None) -> dict[str, str]:
    """The environment of a child process: ``env`` (default: this process's) without
    :data:`UNSET`, ``tests/`` first on ``PYTHONPATH``, then ``overrides`` (None: removed)."""
    out = dict(os.environ if env is None else env)
    for key in UNSET:
        out.pop(key, None)
    paths = [str(TESTS), *[p for p in out.get("PYTHONPATH", "").split(os.pathsep) if p]]
    out["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
    for key, value in overrides.items():
        if value is None:
            out.pop(key, None)
        else:
            out[key] = value
    return out


def home_env(home: Path) -> dict[str, str]:
    """HOME and the XDG directories of a process, all under ``home`` (created)."""
    env = {"HOME": str(home)}
    for var, sub in (
        ("XDG_CONFIG_HOME", ".config"),
        ("XDG_CACHE_HOME", ".cache"),
        ("XDG_DATA_HOME", ".local/share"),
        ("XDG_STATE_HOME", ".local/state"),
    ):
        (home / sub).mkdir(parents=True, exist_ok=True)
        env[var] = str(home / sub)
    return env


def bowlrec_command(*args: str) -> list[str]:
    """``bowlrec ARGS`` through this interpreter (the entry point's module)."""
    return [sys.executable, "-m", "bowlrec.cli", *args]


def child_command(name: str, *args: str) -> list[str]:
    """``python -m helpers.NAME ARGS`` (a child script of this package; see :func:`child_env`)."""
    return [sys.executable, "-m", f"helpers.{name}", *args]


def run_bowlrec(
    *args: str,
    env: Mapping[str, str] | None = None,
    timeout: float = 600.0,
    **kw: Any,
) -> subprocess.CompletedProcess[str]:
    """``bowlrec ARGS`` in a real process, stdout and stderr pipes (not a terminal), text.

    ``env``: variables added to (or, with None values, removed from) :func:`child_env`; other
    keywords go to :func:`subprocess.run` (``cwd``, ``input``...)."""
    overrides = dict(env or {})
    return subprocess.run(
        bowlrec_command(*args),
        capture_output=True,
        text=True,
        env=child_env(None, **overrides),
        timeout=timeout,
        **kw,
    )
