"""One exception hierarchy (:mod:`bowlrec.errors`): every error class of the package derives
from BowlrecError through one category, and the command line and the service each map a
category to one exit code and one HTTP status."""

from __future__ import annotations

import importlib
import inspect
import json
import pkgutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec import errors as E
from bowlrec.archive import Archive
from bowlrec.cli import app
from bowlrec.cli._common import EXIT_CODES

runner = CliRunner()

#: the categories, each with the exit code and HTTP status the docs promise
CATEGORIES: dict[type[E.BowlrecError], tuple[int, int]] = {
    E.InputError: (2, 422),
    E.NotFoundError: (1, 404),
    E.ConflictError: (2, 409),
    E.BusyError: (1, 503),
    E.DamagedError: (1, 409),
    E.StorageError: (1, 507),
    E.UnavailableError: (1, 501),
}

#: one error of each category, as the code raises it
SAMPLES: list[E.BowlrecError] = [
    E.IndexQueryError("unknown column 'nope' in filter"),
    E.RunNotFoundError("no run '0123abcd'"),
    E.JobConflictError("job 0123 is already done"),
    E.ServerBusyError("the server is busy: retry later"),
    E.RunDamagedError("0123abcd", "seg1", "digest mismatch"),
    E.ArchiveWriteError("could not write a segment (disk full); nothing already archived was lost"),
    E.MissingExtraError("MCAP needs foxglove, which is not installed", name="foxglove"),
]

#: the builtin base each class keeps, so that ``except <builtin>`` in callers still works
BUILTIN_BASES: dict[type[E.BowlrecError], type[Exception]] = {
    E.SpecError: ValueError,
    E.SceneInputError: ValueError,
    E.JobError: ValueError,
    E.SpecFileError: ValueError,
    E.IllegalBallError: ValueError,
    E.AimError: ValueError,
    E.BallRefError: ValueError,
    E.IndexQueryError: ValueError,
    E.UnknownFormatError: ValueError,
    E.RunFileError: ValueError,
    E.ConfigError: ValueError,
    E.ArchiveError: RuntimeError,
    E.MigrationError: RuntimeError,
    E.RunNotFoundError: KeyError,
    E.BallNotFoundError: KeyError,
    E.JobNotFoundError: KeyError,
    E.SamplesRequiredError: ValueError,
    E.JobConflictError: RuntimeError,
    E.JobsLockedError: RuntimeError,
    E.ServerBusyError: RuntimeError,
    E.RunDamagedError: ValueError,
    E.SegmentError: ValueError,
    E.IndexUnreadableError: RuntimeError,
    E.ArchiveWriteError: OSError,
    E.MissingExtraError: ImportError,
    E.ViewerUnavailableError: RuntimeError,
}


def _category(err: E.BowlrecError) -> type[E.BowlrecError]:
    return next(kind for kind in CATEGORIES if isinstance(err, kind))


def _package_exceptions() -> set[type[BaseException]]:
    """Every exception class defined in a bowlrec module (each module imported)."""
    for info in pkgutil.walk_packages(bowlrec.__path__, "bowlrec."):
        if not info.name.endswith("__main__"):  # runs the command line
            importlib.import_module(info.name)
    return {
        obj
        for name, module in list(sys.modules.items())
        if (name == "bowlrec" or name.startswith("bowlrec.")) and module is not None
        for obj in vars(module).values()
        if inspect.isclass(obj)
        and issubclass(obj, BaseException)
        and obj.__module__.split(".")[0] == "bowlrec"
    }


def test_every_exception_class_of_the_package_is_a_bowlrec_error() -> None:
    from bowlrec.service.body_limit import BodyTooLargeError

    found = _package_exceptions()
    # the body limit's signal is an HTTPException by design: FastAPI lets only those through
    # its body parsing, and the middleware answers 413 for it; it never reaches a caller
    outside = {c for c in found if not issubclass(c, E.BowlrecError)} - {BodyTooLargeError}
    assert not outside, sorted(c.__qualname__ for c in outside)
    assert set(E.__all__) <= {c.__name__ for c in found}
    for cls in found - {BodyTooLargeError, E.BowlrecError, *CATEGORIES}:
        kinds = [kind for kind in CATEGORIES if issubclass(cls, kind)]
        assert len(kinds) == 1, (cls, kinds)


def test_concrete_errors_keep_their_builtin_base() -> None:
    concrete = {getattr(E, n) for n in E.__all__} - {E.BowlrecError, *CATEGORIES}
    assert set(BUILTIN_BASES) == concrete
    for cls, builtin in BUILTIN_BASES.items():
        assert issubclass(cls, builtin), cls
    with pytest.raises(KeyError):
        raise E.RunNotFoundError("no run 'x'")
    assert str(E.BallNotFoundError("no ball 'x'")) == "no ball 'x'"  # not KeyError's quotes


def test_the_front_ends_map_every_category() -> None:
    from bowlrec.service.app import STATUS_CODES

    assert {k: v[0] for k, v in CATEGORIES.items()} == EXIT_CODES
    assert {k: v[1] for k, v in CATEGORIES.items()} == STATUS_CODES
    assert set(CATEGORIES) == set(E.BowlrecError.__subclasses__())
    assert [_category(e) for e in SAMPLES] == list(CATEGORIES)


@pytest.mark.process  # a fresh interpreter's modules
def test_errors_module_loads_only_the_standard_library() -> None:
    code = (
        "import json, sys; before = set(sys.modules); import bowlrec.errors; "
        "print(json.dumps(sorted(set(sys.modules) - before)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    new = json.loads(out.stdout)
    assert not {m.split(".")[0] for m in new} & {"pydantic", "numpy", "typer", "fastapi"}, new


def test_illegal_ball_error_takes_plain_values_and_pickles() -> None:
    """errors.py knows nothing of the legality check: the check writes the lines."""
    import pickle

    err = E.IllegalBallError("heavy", "current", ["weight_max 16.5 lb (limit 16 lb)"])
    assert str(err) == (
        "ball 'heavy' is illegal under rule set 'current': weight_max 16.5 lb (limit 16 lb); "
        "set allow_illegal to true to simulate it anyway"
    )
    back = pickle.loads(pickle.dumps(err))
    assert (type(back), str(back), back.violations) == (type(err), str(err), err.violations)


# -- the command line ----------------------------------------------------------------------------


@pytest.mark.parametrize("err", SAMPLES, ids=lambda e: type(e).__name__)
def test_cli_exit_code_of_each_category(
    err: E.BowlrecError, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    Archive(tmp_path / "a")

    def fails(*args: Any, **kw: Any) -> Any:
        raise err

    monkeypatch.setattr(Archive, "list_runs", fails)
    result = runner.invoke(app, ["runs", "list", "-a", str(tmp_path / "a")])
    assert result.exit_code == CATEGORIES[_category(err)][0]
    assert result.output == f"error: {err}\n"


@pytest.mark.process  # serve binds a socket before the lock refuses it
def test_cli_errors_from_real_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    arch = str(Archive(tmp_path / "a").root)
    # input: an output file of unknown type (refused before simulating)
    bad = runner.invoke(app, ["simulate", "--no-archive", "--out", str(tmp_path / "r.txt")])
    assert bad.exit_code == 2 and "unknown suffix '.txt'" in bad.output
    # not found
    missing = runner.invoke(app, ["runs", "show", "0123abcd", "-a", arch])
    assert missing.exit_code == 1 and "no run '0123abcd'" in missing.output
    # conflict: serving an archive whose jobs another server runs (its jobs lock is held)
    pytest.importorskip("fastapi")
    from bowlrec.cli import serve as _serve  # noqa: F401  (registers the command)
    from bowlrec.service.jobs import JobManager

    holder = JobManager(Archive(arch))
    holder.open()
    try:
        locked = runner.invoke(app, ["serve", "-a", arch, "--port", "0"])
    finally:
        holder.stop()
    assert locked.exit_code == 2 and "another bowlrec server" in locked.output
    # input: a config file that is not TOML
    config = tmp_path / "config.toml"
    config.write_text("archive = \n")
    monkeypatch.setenv("BOWLREC_CONFIG", str(config))
    monkeypatch.delenv("BOWLREC_ARCHIVE", raising=False)
    broken = runner.invoke(app, ["runs", "list"])
    assert broken.exit_code == 2 and "not valid TOML" in broken.output
    assert broken.output.count("\n") == 1


# -- the service ---------------------------------------------------------------------------------


@pytest.mark.parametrize("err", SAMPLES, ids=lambda e: type(e).__name__)
def test_service_status_of_each_category(
    err: E.BowlrecError, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    from bowlrec.service.app import create_app

    service = create_app(tmp_path / "a", warm_up=False)

    def fails(*args: Any, **kw: Any) -> Any:
        raise err

    monkeypatch.setattr(service.state.bowlrec.archive, "list_runs", fails)
    with TestClient(service, base_url="http://127.0.0.1") as client:
        r = client.get("/runs")
    assert r.status_code == CATEGORIES[_category(err)][1], r.text
    assert r.json() == {"detail": str(err)}
    assert (r.headers.get("retry-after") == "1") == isinstance(err, E.BusyError)


def test_service_errors_from_real_requests(app_server: Any) -> None:
    """Requests to the app (in process): an invalid filter, an unknown run and cancelling a
    finished job are answered by their category's status."""
    pytest.importorskip("httpx")
    server = app_server()
    try:
        with server.client() as client:
            bad = client.get("/runs", params={"where": "nope>1"})
            assert bad.status_code == 422 and "unknown column 'nope'" in bad.json()["detail"]
            assert client.get("/runs/0123abcd").status_code == 404
            job = client.post("/jobs", json={"scenes": [{"options": {"record": "summary"}}]})
            job_id = job.json()["job_id"]
            deadline = time.monotonic() + 60
            while client.get(f"/jobs/{job_id}").json()["status"] in ("queued", "running"):
                assert time.monotonic() < deadline
                time.sleep(0.05)
            cancel = client.post(f"/jobs/{job_id}/cancel")
            assert cancel.status_code == 409, cancel.text
            assert cancel.json()["detail"] == (
                f"job {job_id} is done; only queued or running jobs can be cancelled"
            )
    finally:
        server.stop()
