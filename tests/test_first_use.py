"""First use: ``bowlrec warm``, the check of numba's cache without numba
(``bowlrec.core.warm.missing``) and the notice a command prints before it compiles."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from bowlrec.cli import app
from bowlrec.core import _kernel_cache as kc
from bowlrec.core import warm
from bowlrec.core.warm import GROUPS, WarmUp, WarmUpError, missing

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "bowlrec" / "core"
CASE01 = ROOT / "examples" / "paper" / "case01.json"  # a uniform ball
runner = CliRunner()


def _summary_scene(tmp_path: Path) -> Path:
    """Case 1 recording its summary only: the closed form."""
    scene = json.loads(CASE01.read_text())
    scene["options"] = {**scene.get("options", {}), "record": "summary"}
    path = tmp_path / "case01-summary.json"
    path.write_text(json.dumps(scene))
    return path


def _warm_cache() -> Path:
    cache = kc.numba_cache_dir(CORE)
    assert cache is not None
    return cache


def _copy(cache: Path, to: Path) -> Path:
    """A copy of the cache directory's numba entries and bowlrec's stamp."""
    to.mkdir()
    for f in cache.iterdir():
        if f.suffix in (".nbi", ".nbc") or f.name == kc.STAMP:
            shutil.copy2(f, to / f.name)
    return to


# -- the check, in process -----------------------------------------------------------------------


def test_numba_cache_dir_is_numbas_choice(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from numba.core import config

    assert kc.numba_cache_dir(CORE) == kc.kernel_cache_dir(CORE)
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path))
    assert kc.numba_cache_dir(CORE) == kc.kernel_cache_dir(CORE)
    assert kc.numba_cache_dir(CORE).parent == tmp_path  # type: ignore[union-attr]


def test_the_warmed_cache_lacks_nothing() -> None:
    """The test session warmed every variant (tests/conftest.py): the entries each variant
    needs (warm.ENTRIES) are all found, signatures included."""
    assert missing() == []
    signatures = kc.cached_signatures(_warm_cache(), CORE / "integrator.py", "simulate_kernel")
    stations = {sig[15] for sig in signatures}
    assert "none" in stations and any(s.startswith("array") for s in stations)


def test_an_empty_cache_lacks_every_variant(tmp_path: Path) -> None:
    assert missing(cache_dir=tmp_path) == list(GROUPS["all"])
    assert missing("batch", cache_dir=tmp_path) == ["integrator", "batch_serial"]


def test_a_missing_entry_is_missing_and_only_its_variants(tmp_path: Path) -> None:
    cache = _copy(_warm_cache(), tmp_path / "cache")
    assert missing(cache_dir=cache) == []
    for f in cache.glob("batch._run_parallel-*"):
        f.unlink()
    assert missing(cache_dir=cache) == ["batch_parallel"]
    for f in cache.glob("integrator.simulate_kernel-*.nbc"):
        f.unlink()  # the index names data files that are gone
    assert missing("service", cache_dir=cache) == ["integrator"]
    assert missing("observe", cache_dir=cache) == ["observe"]


def test_an_index_of_other_sources_or_another_numba_holds_nothing(tmp_path: Path) -> None:
    cache = _copy(_warm_cache(), tmp_path / "cache")
    index = next(cache.glob("closed_form.closed_form_kernel-*.nbi"))
    source = CORE / "closed_form.py"
    assert kc.cached_signatures(cache, source, "closed_form_kernel")
    other = tmp_path / "closed_form.py"
    other.write_text(source.read_text() + "\n# edited\n")
    assert kc.cached_signatures(cache, other, "closed_form_kernel") == []
    index.write_bytes(index.read_bytes().replace(b"0.", b"9.", 1))  # numba's version
    assert kc.cached_signatures(cache, source, "closed_form_kernel") == []
    index.write_bytes(b"not a pickle")
    assert kc.cached_signatures(cache, source, "closed_form_kernel") == []


# -- bowlrec warm, in process ----------------------------------------------------------------------


def _fake_warm_up(*names: str, progress: Any = None, **kw: Any) -> WarmUp:
    for name in names:
        progress(name, False)
        progress(name, True)
    return WarmUp(names=names, seconds=1.25, cpu_seconds=1.0, compiled=3, loaded=4)


def test_warm_prints_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(warm, "warm_up", _fake_warm_up)
    result = runner.invoke(app, ["warm", "--quiet"])
    assert result.exit_code == 0, result.output
    assert result.stdout == "warm: 1.2 s, 3 kernels compiled, 4 loaded from numba's cache\n"
    assert result.stderr == ""


def test_warm_shows_a_failure(monkeypatch: pytest.MonkeyPatch) -> None:
    def failing(*names: str, **kw: Any) -> WarmUp:
        try:
            raise ValueError("no LLVM today")
        except ValueError as err:
            raise WarmUpError("kernel variant observe failed: ValueError('no LLVM today')") from err

    monkeypatch.setattr(warm, "warm_up", failing)
    result = runner.invoke(app, ["warm"])
    assert result.exit_code == 1
    assert "error: kernel variant observe failed" in result.stderr
    assert "ValueError: no LLVM today" in result.stderr  # the cause's traceback


def test_warm_up_reports_progress_and_names_a_failing_variant(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: list[tuple[str, bool]] = []
    monkeypatch.setitem(warm.VARIANTS, "closed_form", lambda: None)
    warm.warm_up("closed_form", progress=lambda n, d: seen.append((n, d)))
    assert seen == [("closed_form", False), ("closed_form", True)]

    def boom() -> None:
        raise ZeroDivisionError

    monkeypatch.setitem(warm.VARIANTS, "closed_form", boom)
    with pytest.raises(WarmUpError, match="closed_form") as err:
        warm.warm_up("closed_form")
    assert isinstance(err.value.__cause__, ZeroDivisionError)


# -- the notice, in process (the check stubbed) ----------------------------------------------------


@pytest.mark.parametrize("lacking", [["closed_form"], []])
def test_the_notice_goes_to_stderr_with_quiet_and_json(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, lacking: list[str]
) -> None:
    asked: list[tuple[str, ...]] = []

    def fake_missing(*names: str, **kw: Any) -> list[str]:
        asked.append(names)
        return lacking

    monkeypatch.setattr(warm, "missing", fake_missing)
    scene = _summary_scene(tmp_path)
    result = runner.invoke(app, ["simulate", str(scene), "--no-archive", "--json", "--quiet"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["outcome"]  # stdout stays the command's output
    assert asked == [("closed_form",)]  # a uniform ball, summary only: the closed form
    if lacking:
        assert result.stderr.startswith("first use: compiling the kernels this command needs")
        assert "closed_form" in result.stderr and "'bowlrec warm'" in result.stderr
        assert len(result.stderr.splitlines()) == 1
    else:
        assert result.stderr == ""


# -- real processes, real compiles (a fresh numba cache of their own) ------------------------------


@pytest.mark.process
def test_first_use_notice_with_a_cold_cache_only(run_bowlrec: Any, tmp_path: Path) -> None:
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    args = ("simulate", str(_summary_scene(tmp_path)), "--no-archive", "--json", "--quiet")
    cold = run_bowlrec(*args, env=env)
    assert cold.returncode == 0, cold.stderr
    assert cold.stderr.startswith("first use: compiling the kernels this command needs (closed")
    assert json.loads(cold.stdout)["outcome"]
    again = run_bowlrec(*args, env=env)
    assert again.returncode == 0 and again.stderr == ""
    assert json.loads(again.stdout) == json.loads(cold.stdout)


@pytest.mark.process
def test_warm_compiles_in_a_fresh_cache_then_loads_only(run_bowlrec: Any, tmp_path: Path) -> None:
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    first = run_bowlrec("warm", env=env, timeout=1800)
    assert first.returncode == 0, first.stderr
    line = first.stdout.strip()
    compiled = int(line.split(", ")[1].split()[0])
    assert line.startswith("warm: ") and compiled > 0
    assert first.stderr == ""  # not a terminal: no progress bar
    again = run_bowlrec("warm", env=env)
    assert again.returncode == 0
    assert ", 0 kernels compiled, " in again.stdout
    check = "import json, sys; from bowlrec.core.warm import missing; "
    check += "print(json.dumps([missing(), 'numba' in sys.modules]))"
    import subprocess
    import sys

    from helpers.processes import child_env

    out = subprocess.run(
        [sys.executable, "-c", check],
        env=child_env(**env),
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(out.stdout) == [[], False]  # all there, read without numba


def test_scene_variants_follow_what_the_run_records() -> None:
    from bowlrec.cli._first_use import scene_variants
    from bowlrec.spec import Scene

    scene = Scene.model_validate(json.loads(CASE01.read_text()))  # a uniform ball, every step
    assert scene_variants(scene) == ("rate",)
    assert scene_variants(scene, summary_only=True) == ("closed_form",)  # --no-archive, no file
    assert scene_variants(scene, observed=True, summary_only=True) == ("closed_form", "observe")


def test_a_bowler_scene_file_gets_the_notice_before_it_is_read(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Reading a bowler scene simulates (its launch angle is solved): the notice comes first,
    once per process."""
    from bowlrec.cli import _first_use

    monkeypatch.setattr(_first_use, "_shown", [])
    monkeypatch.setattr(warm, "missing", lambda *names, **kw: list(names))
    bowler = ROOT / "examples" / "bowler" / "house-shot-right.json"
    assert _first_use.first_use_of_file(tmp_path / "none.json") == []
    assert _first_use.first_use_of_file(_summary_scene(tmp_path)) == []
    assert _first_use.first_use_of_file(bowler) == ["observe", "integrator"]
    assert _first_use.first_use("integrator") == ["integrator"]
    err = capsys.readouterr().err
    assert err.count("first use:") == 1 and "(observe, integrator; about" in err
