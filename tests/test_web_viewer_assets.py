"""The rerun web viewer's files copied out of rerun-sdk (:mod:`bowlrec.web.viewer_assets`).

One extraction (a child process serving rerun's web viewer, ~43 MB) is shared by the module;
the damage and concurrency tests extract again into their own directories.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
import threading
from importlib.util import find_spec
from pathlib import Path

import pytest

from bowlrec.errors import MissingExtraError, NotFoundError, UnavailableError
from bowlrec.web import viewer_assets
from bowlrec.web.viewer_assets import (
    VIEWER_VERSION,
    ViewerAssets,
    default_cache_root,
    remote_fetches,
    rewrite_index,
)

needs_rerun = pytest.mark.skipif(
    find_spec("rerun") is None or viewer_assets.installed_rerun_version() != VIEWER_VERSION,
    reason=f"rerun-sdk {VIEWER_VERSION} is not installed",
)

DIR_NAME = f"rerun-web-viewer-{VIEWER_VERSION}"
#: the extraction runs rerun's server in a child process: its users are in the process tier
FIXTURE_TIERS = {"extracted": "process"}


@pytest.fixture(scope="module")
def extracted(tmp_path_factory: pytest.TempPathFactory) -> ViewerAssets:
    """The viewer extracted once into a temporary cache."""
    if find_spec("rerun") is None or viewer_assets.installed_rerun_version() != VIEWER_VERSION:
        pytest.skip(f"rerun-sdk {VIEWER_VERSION} is not installed")
    assets = ViewerAssets(tmp_path_factory.mktemp("cache") / DIR_NAME)
    assets.ensure()
    return assets


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def assert_valid_cache(directory: Path) -> dict[str, object]:
    """Every file of the manifest has its size and SHA-256; nothing is left beside it."""
    manifest = json.loads((directory / "manifest.json").read_text())
    assert manifest["rerun_version"] == VIEWER_VERSION
    on_disk = {p.name for p in directory.iterdir()} - {"manifest.json"}
    assert on_disk == set(manifest["files"])
    for name, entry in manifest["files"].items():
        assert (directory / name).stat().st_size == entry["size"], name
        assert sha256(directory / name) == entry["sha256"], name
    leftovers = {p.name for p in directory.parent.iterdir()} - {DIR_NAME, f".{DIR_NAME}.lock"}
    assert not leftovers, leftovers
    return manifest  # type: ignore[no-any-return]


# the test's own reading of what a page loads: attributes and literal call arguments
ATTR = re.compile(r"""\b(?:src|href)\s*=\s*(["'])(.*?)\1""", re.DOTALL)
CALL = re.compile(r"""\b(?:fetch|import|importScripts|register|new URL)\(\s*(["'])(.*?)\1""")


def requested_urls(text: str) -> set[str]:
    return {m.group(2) for pattern in (ATTR, CALL) for m in pattern.finditer(text)}


def is_local(url: str) -> bool:
    return not re.match(r"[a-z][a-z0-9+.-]*:|//|#|\$\{", url, re.IGNORECASE)


# -- extraction --------------------------------------------------------------------------


def test_extraction_writes_every_file_with_its_checksum(extracted: ViewerAssets) -> None:
    manifest = assert_valid_cache(extracted.directory)
    files = manifest["files"]
    assert isinstance(files, dict)
    assert {"index.html", "re_viewer.js", "re_viewer_bg.wasm", "favicon.ico"} <= set(files)
    assert "sw.js" not in files and "sw.js" in manifest["not_served"]  # type: ignore[operator]
    assert files["re_viewer_bg.wasm"]["size"] > 10_000_000
    assert extracted.names() == sorted(files)


def test_every_local_url_of_the_page_is_served(extracted: ViewerAssets) -> None:
    served = set(extracted.names())
    for page in ("index.html", "re_viewer.js"):
        text = extracted.path(page).read_text("utf-8")
        local = {u.removeprefix("./") for u in requested_urls(text) if is_local(u)}
        assert local <= served, (page, local - served)
    index = extracted.path("index.html").read_text("utf-8")
    assert {"re_viewer.js", "re_viewer_bg.wasm", "favicon.ico"} <= {
        u.removeprefix("./") for u in requested_urls(index)
    }


def test_index_html_requests_nothing_off_the_machine(extracted: ViewerAssets) -> None:
    html = extracted.path("index.html").read_text("utf-8")
    assert "fonts.googleapis.com" not in html and "fonts.gstatic.com" not in html
    assert "fifteen-thirtyeight.rerun.io" not in html
    assert not [u for u in requested_urls(html) if not is_local(u) and "${" not in u and u != "#"]
    assert remote_fetches(html) == []
    # what remains: bug-report links shown in error messages and a comment
    text = re.sub(r"<!--.*?-->", "", html, flags=re.DOTALL)
    for match in re.finditer(r"https?://\S+", text):
        assert text[: match.start()].endswith("<a href="), match.group(0)
    rewrite = extracted.manifest()["rewritten"]["index.html"]
    removed = " ".join(change.get("removed", "") for change in rewrite["changes"])
    assert html.index("not contacted (offline viewer)") < html.index("re_viewer.js")
    assert "fonts.googleapis.com" in removed and "fifteen-thirtyeight" in removed
    assert rewrite["original_sha256"] != extracted.manifest()["files"]["index.html"]["sha256"]


def test_wasm_is_wasm_and_matches_its_checksum(extracted: ViewerAssets) -> None:
    wasm = extracted.path("re_viewer_bg.wasm")
    assert wasm.read_bytes()[:4] == b"\0asm"
    assert sha256(wasm) == extracted.manifest()["files"]["re_viewer_bg.wasm"]["sha256"]


def test_media_types() -> None:
    assert ViewerAssets.media_type("re_viewer_bg.wasm") == "application/wasm"
    assert ViewerAssets.media_type("re_viewer.js") == "text/javascript"
    assert ViewerAssets.media_type("index.html") == "text/html; charset=utf-8"
    assert ViewerAssets.media_type("favicon.ico") == "image/x-icon"


@pytest.mark.parametrize(
    "name",
    ["../manifest.json", "nope", "manifest.json", "sw.js", "", "/etc/passwd",
     "re_viewer.js/../manifest.json", "./index.html", ".", "..", "INDEX.HTML"],
)  # fmt: skip
def test_path_refuses_names_outside_the_manifest(extracted: ViewerAssets, name: str) -> None:
    with pytest.raises(NotFoundError):
        extracted.path(name)


def test_a_valid_cache_is_reused_without_rerun(
    extracted: ViewerAssets, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(viewer_assets, "installed_rerun_version", lambda: None)
    monkeypatch.setattr(viewer_assets, "_VERIFIED", set())  # full check, as in a new process
    assets = ViewerAssets(extracted.directory)
    assert assets.ensure() == extracted.directory
    assert assets.path("re_viewer.js").is_file()


# -- damage ------------------------------------------------------------------------------


@needs_rerun
def test_truncated_file_is_detected_and_extracted_again(
    extracted: ViewerAssets, tmp_path: Path
) -> None:
    directory = tmp_path / DIR_NAME
    shutil.copytree(extracted.directory, directory)
    assets = ViewerAssets(directory)
    assets.ensure()
    wasm = directory / "re_viewer_bg.wasm"
    with wasm.open("r+b") as f:
        f.truncate(1000)
    (directory / "favicon.ico").unlink()
    assert assets.path("re_viewer_bg.wasm") == wasm  # the size check sees it
    assert_valid_cache(directory)


@needs_rerun
def test_same_size_damage_is_caught_by_the_first_check_of_a_process(
    extracted: ViewerAssets, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    directory = tmp_path / DIR_NAME
    shutil.copytree(extracted.directory, directory)
    js = directory / "re_viewer.js"
    data = bytearray(js.read_bytes())
    data[100] ^= 0xFF
    js.write_bytes(bytes(data))
    monkeypatch.setattr(viewer_assets, "_VERIFIED", set())
    ViewerAssets(directory).ensure()
    assert js.read_bytes() == extracted.path("re_viewer.js").read_bytes()
    assert_valid_cache(directory)


@needs_rerun
def test_a_damaged_manifest_is_extracted_again(extracted: ViewerAssets, tmp_path: Path) -> None:
    directory = tmp_path / DIR_NAME
    shutil.copytree(extracted.directory, directory)
    (directory / "manifest.json").write_text("{not json")
    ViewerAssets(directory).ensure()
    assert_valid_cache(directory)


# -- concurrency -------------------------------------------------------------------------


@pytest.mark.process  # extraction runs rerun's server in a child process
@needs_rerun
def test_threads_extracting_at_once_end_with_one_valid_cache(tmp_path: Path) -> None:
    directory = tmp_path / DIR_NAME
    results: list[Path] = []
    errors: list[BaseException] = []

    def work() -> None:
        try:
            results.append(ViewerAssets(directory).ensure())
        except BaseException as err:  # reported below
            errors.append(err)

    threads = [threading.Thread(target=work) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    assert not errors and results == [directory] * 3
    assert_valid_cache(directory)


@pytest.mark.process  # extraction runs rerun's server in a child process
@needs_rerun
def test_processes_extracting_at_once_end_with_one_valid_cache(tmp_path: Path) -> None:
    directory = tmp_path / DIR_NAME
    code = (
        "import sys; from pathlib import Path; "
        "from bowlrec.web.viewer_assets import ViewerAssets; "
        "a = ViewerAssets(Path(sys.argv[1])); a.ensure(); "
        "m = a.manifest(); print(m['extracted_at'], m['extract_seconds'], 'rerun' in sys.modules)"
    )
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", code, str(directory)], stdout=subprocess.PIPE, text=True
        )
        for _ in range(2)
    ]
    outputs = [proc.communicate(timeout=300)[0].split() for proc in procs]
    assert [proc.returncode for proc in procs] == [0, 0]
    assert outputs[0] == outputs[1]  # the second found the first's cache
    assert outputs[0][2] == "False"  # rerun is imported only in the download child
    assert_valid_cache(directory)


# -- without extraction ------------------------------------------------------------------


def test_missing_or_wrong_rerun_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(viewer_assets, "installed_rerun_version", lambda: None)
    with pytest.raises(MissingExtraError, match=r"pip install 'bowlrec\[rerun\]'") as err:
        ViewerAssets(tmp_path / DIR_NAME).ensure()
    assert isinstance(err.value, UnavailableError) and "\n" not in str(err.value)
    monkeypatch.setattr(viewer_assets, "installed_rerun_version", lambda: "0.40.1")
    with pytest.raises(UnavailableError, match=rf"pip install 'rerun-sdk=={VIEWER_VERSION}'"):
        ViewerAssets(tmp_path / DIR_NAME).ensure()
    assert not (tmp_path / DIR_NAME).exists()


@pytest.mark.process  # a fresh interpreter's modules
def test_importing_the_module_does_not_import_rerun() -> None:
    code = "import sys, bowlrec.web.viewer_assets; print('rerun' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_default_cache_root(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("BOWLREC_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_cache_root() == tmp_path / "home" / ".cache" / "bowlrec" / DIR_NAME
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_root() == tmp_path / "xdg" / "bowlrec" / DIR_NAME
    monkeypatch.setenv("BOWLREC_CACHE_DIR", str(tmp_path / "own"))
    assert default_cache_root() == tmp_path / "own" / DIR_NAME
    assert ViewerAssets().directory == tmp_path / "own" / DIR_NAME


def test_rewrite_index_drops_remote_and_missing_links() -> None:
    html = (
        '<head>\n  <link rel="icon" href="favicon.ico" />\n'
        '  <link rel="apple-touch-icon" href="apple-touch-icon.png" />\n'
        '  <link\n    href="https://fonts.googleapis.com/css2?family=Inter"\n'
        '    rel="stylesheet"\n  />\n'
        "</head>\n"
    )
    out, changes = rewrite_index(html, {"favicon.ico", "index.html"})
    assert 'href="favicon.ico"' in out
    assert "apple-touch-icon" not in out and "fonts.googleapis" not in out
    assert [c.get("removed", "added") for c in changes][2] == "added"
    assert len(changes) == 3 and "not contacted (offline viewer)" in out
    assert remote_fetches(out) == []


def test_remote_fetches_tells_links_from_loads() -> None:
    assert remote_fetches("<a href=https://github.com/x>bug</a><!-- https://e.x/ -->") == []
    assert remote_fetches('<script src="https://cdn.example/x.js"></script>') == [
        "https://cdn.example/x.js"
    ]
    assert remote_fetches("<img src=https://e.x/a.png>") == ["https://e.x/a.png"]
