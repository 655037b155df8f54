"""The Python API's inputs: what a caller passes wrong is one bowlrec error naming it, and the
documented forms of an input are all taken."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from bowlrec import simulate_many
from bowlrec.api import simulate_into
from bowlrec.archive import Archive
from bowlrec.errors import ArchiveError, ArchiveWriteError, JobError, UnknownFormatError
from bowlrec.versions import PHYSICS_VERSION

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "scene.yaml"


@pytest.mark.parametrize(
    ("args", "kwargs", "words"),
    [
        (({"sweep": {"kind": "grid"}},), {}, "sweep.grid.axes: Field required"),
        (([],), {}, "no scenes"),
        ((5,), {}, "a sequence of scenes, not int"),
        (([{}, 5],), {}, "scenes[1]: a scene must be"),
        (([{}],), {"workers": -1}, "workers = -1 must be an integer >= 0"),
        (([{}],), {"workers": "two"}, "workers = 'two' must be an integer >= 0"),
        (([{}],), {"output": "pandas"}, "output = 'pandas' must be 'arrow' or 'numpy'"),
    ],
)
def test_simulate_many_refuses_what_it_cannot_run_with_a_job_error(
    args: tuple[Any, ...], kwargs: dict[str, Any], words: str
) -> None:
    with pytest.raises(JobError, match=re.escape(words)) as info:
        simulate_many(*args, **kwargs)
    assert "\n" not in str(info.value)


def test_simulate_into_takes_every_form_simulate_takes(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    by_mapping = simulate_into(archive, {"delivery": {"speed_mps": 8.0}})
    by_path = simulate_into(archive, SCENE)
    bowler = simulate_into(archive, str(ROOT / "examples" / "bowler" / "pocket-right.json"))
    assert by_mapping.added and by_path.added and bowler.added
    assert not simulate_into(archive, str(SCENE)).added  # the same run ID as the path's


def test_an_archive_cannot_be_made_on_a_file_or_an_unwritable_place(tmp_path: Path) -> None:
    a_file = tmp_path / "taken"
    a_file.write_text("")
    with pytest.raises(ArchiveError, match="is a file, not an archive directory"):
        Archive(a_file)
    if Path("/proc/self").exists():
        with pytest.raises(ArchiveWriteError, match="/proc/bowlrec-x: cannot create an archive"):
            Archive("/proc/bowlrec-x")


def test_export_writes_the_format_its_suffix_names(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    rid = simulate_into(archive, SCENE).run_id
    assert archive.export(rid, tmp_path / "r.csv").read_bytes().startswith(b"t_s,")
    assert archive.export(rid, tmp_path / "r.mcap").read_bytes()[:4] == b"\x89MCA"
    assert archive.export(rid, tmp_path / "r.h5").read_bytes()[:4] == b"\x89HDF"
    assert archive.export(rid, tmp_path).name == f"{rid}.h5"  # a directory: the run file
    with pytest.raises(UnknownFormatError, match="no suffix to tell the format by"):
        archive.export(rid, tmp_path / "not-there")


def test_a_filter_takes_a_quoted_value_and_a_single_condition(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    simulate_into(archive, {"options": {"record": "summary"}})
    for where in (
        [f"physics_version='{PHYSICS_VERSION}'"],
        [f'physics_version="{PHYSICS_VERSION}"'],
        f"physics_version={PHYSICS_VERSION}",
    ):
        assert len(archive.list_runs(where=where)) == 1, where
