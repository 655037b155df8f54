"""The rerun web viewer's files, copied once out of the installed ``rerun-sdk`` into a cache.

``rerun-sdk`` carries its web viewer inside its compiled extension, and no API returns the
files; only ``rerun.serve_web_viewer`` serves them, from a second HTTP server. So the first time
they are needed a child process (``sys.executable``) starts that server on a free loopback port,
downloads every file the viewer's page loads, and exits, taking rerun's server thread with it.
The parent process never imports ``rerun``.

Layout of the cache (``$BOWLREC_CACHE_DIR``, else ``$XDG_CACHE_HOME/bowlrec``, else
``~/.cache/bowlrec``)::

    rerun-web-viewer-0.41.0/              the directory :meth:`ViewerAssets.ensure` returns
        index.html  re_viewer.js  re_viewer_bg.wasm  favicon.ico  apple-touch-icon.png
        manifest.json                     sizes, SHA-256, rerun version, the index.html rewrite
    .rerun-web-viewer-0.41.0.lock         flock held while the directory is checked or replaced

The files are downloaded into a staging directory beside the final one (each file written to a
temporary name and renamed), checked, and the whole directory is renamed into place, so a reader
sees either no directory or a complete one. The lock file serialises extractions between
processes; a per-directory lock does it between threads.

``index.html`` is rewritten so that the page requests nothing off the machine: the Google Fonts
``<link>`` tags go (the text falls back to the browser's sans-serif), so does a ``<link>`` to a
file rerun's server answers with 404 (none in 0.41.0, which serves every file its page links),
and so does the analytics ``<script>`` the page injects when it is hosted at ``app.rerun.io``.
A short script is put first in ``<head>`` (:data:`OFFSITE_GUARD`): the viewer's own
requests to other hosts (its telemetry and a check for a newer release, made from the wasm)
are answered in the page with an empty 204 and never leave the machine. What was removed and
added is recorded in the manifest. The absolute URLs left in the page are a comment and
``<a href>`` links shown only in error messages (a bug report); nothing fetches them.

``sw.js`` is not copied and not served. rerun's server has it, but neither the page nor
``re_viewer.js`` registers it. It is a cache-first service worker that stores ``./``,
``index.html``, ``re_viewer.js`` and ``re_viewer_bg.wasm`` under one fixed cache name and
answers every request in its scope from that cache before the network, with no versioning or
expiry: once registered it would keep answering with the old viewer after an upgrade and would
intercept every request under ``/viewer/``. The server's own caching headers do its job.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from bowlrec.errors import MissingExtraError, NotFoundError, UnavailableError

__all__ = ["VIEWER_VERSION", "ViewerAssets", "default_cache_root", "remote_fetches"]

#: The ``rerun-sdk`` version whose web viewer is served (pyproject pins ``>=0.41,<0.42``).
VIEWER_VERSION = "0.41.0"

MANIFEST_NAME = "manifest.json"
MANIFEST_FORMAT = 2

#: put first in the page's ``<head>``: the viewer's own requests to other hosts (its telemetry
#: to tel.rerun.io and its check for a newer release on api.github.com, both made from the
#: wasm through ``fetch``) are answered in the page with an empty 204 instead of leaving the
#: machine (a rejected fetch would be logged by the viewer as an error)
OFFSITE_GUARD = """<script>
/* bowlrec serves this viewer offline: requests to other hosts are not made. */
(function () {
  function offsite(url) {
    try {
      var u = new URL(url, location.href);
      return (u.protocol === "http:" || u.protocol === "https:") && u.origin !== location.origin;
    } catch (e) { return false; }
  }
  var realFetch = window.fetch.bind(window);
  window.fetch = function (input, init) {
    var url = typeof input === "string" ? input : (input && input.url) || String(input);
    if (offsite(url)) {
      return Promise.resolve(
        new Response(null, {status: 204, statusText: "not contacted (offline viewer)"}));
    }
    return realFetch(input, init);
  };
  var open = XMLHttpRequest.prototype.open;
  XMLHttpRequest.prototype.open = function (method, url) {
    if (offsite(url)) { throw new TypeError("not contacted (offline viewer)"); }
    return open.apply(this, arguments);
  };
  if (navigator.sendBeacon) {
    var beacon = navigator.sendBeacon.bind(navigator);
    navigator.sendBeacon = function (url, data) {
      return offsite(url) ? false : beacon(url, data);
    };
  }
})();
</script>
"""
#: the guard's SHA-256, kept in the manifest: a cache made with another guard is made anew
GUARD_SHA256 = hashlib.sha256(OFFSITE_GUARD.encode()).hexdigest()

#: Files the viewer cannot start without.
REQUIRED_FILES = ("index.html", "re_viewer.js", "re_viewer_bg.wasm")

#: Files rerun's server has that are deliberately not copied, with the reason.
NOT_SERVED = {
    "sw.js": (
        "a cache-first service worker with a fixed cache name and no expiry; nothing registers "
        "it, and once registered it would serve a stale viewer and intercept /viewer/"
    ),
}

_MEDIA_TYPES = {
    ".wasm": "application/wasm",
    ".js": "text/javascript",
    ".html": "text/html; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".ico": "image/x-icon",
    ".png": "image/png",
    ".svg": "image/svg+xml",
}

_EXTRACT_TIMEOUT_S = 180.0
_SERVER_START_TIMEOUT_S = 30.0
_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_REF_PATTERNS = (
    re.compile(r"""\b(?:src|href)\s*=\s*["']([^"']+)["']"""),
    re.compile(r"""\b(?:fetch|import|importScripts|register)\(\s*["']([^"']+)["']"""),
    re.compile(r"""\bnew\s+URL\(\s*["']([^"']+)["']"""),
)
_URL = re.compile(r"https?://[^\s\"'`<>)]+")
_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)
_LINK_TAG = re.compile(r"[ \t]*<link\b[^>]*>[ \t]*\n?", re.IGNORECASE)
_HREF = re.compile(r"""\bhref\s*=\s*["']([^"']*)["']""", re.IGNORECASE)
_HOSTED_ANALYTICS = re.compile(
    r"[ \t]*if \(window\.location\.hostname == \"app\.rerun\.io\"\) \{[^{}]*\}[ \t]*\n"
)

# Directories checked against their SHA-256 in this process, and one lock per directory.
_VERIFIED: set[Path] = set()
_DIR_LOCKS: dict[Path, threading.Lock] = {}
_DIR_LOCKS_GUARD = threading.Lock()


def default_cache_root() -> Path:
    """``rerun-web-viewer-<VIEWER_VERSION>`` in ``$BOWLREC_CACHE_DIR``, else in
    ``$XDG_CACHE_HOME/bowlrec``, else in ``~/.cache/bowlrec``."""
    name = f"rerun-web-viewer-{VIEWER_VERSION}"
    if os.environ.get("BOWLREC_CACHE_DIR"):
        return Path(os.environ["BOWLREC_CACHE_DIR"]).expanduser() / name
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]).expanduser() / "bowlrec" / name
    return Path.home() / ".cache" / "bowlrec" / name


def local_references(text: str) -> set[str]:
    """The same-directory files a page or script names in ``src=``/``href=`` attributes and
    ``fetch``/``import``/``importScripts``/``register``/``new URL`` calls with a literal
    argument (``./x.js`` as ``x.js``). Absolute URLs, fragments, ``data:`` and template
    placeholders are not local references."""
    refs: set[str] = set()
    for pattern in _REF_PATTERNS:
        for match in pattern.finditer(text):
            ref = match.group(1).strip()
            if not ref or "${" in ref or ref.startswith(("#", "//", "?")):
                continue
            if re.match(r"[A-Za-z][A-Za-z0-9+.-]*:", ref):  # http:, data:, javascript: ...
                continue
            ref = ref.split("#", 1)[0].split("?", 1)[0]
            while ref.startswith("./"):
                ref = ref[2:]
            if ref:
                refs.add(ref)
    return refs


def remote_fetches(html: str) -> list[str]:
    """Absolute URLs in ``html`` that a browser could request without a click: every
    ``http(s)://`` URL outside comments except the targets of ``<a href=...>`` links."""
    text = _COMMENT.sub("", html)
    found = []
    for match in _URL.finditer(text):
        before = text[max(0, match.start() - 12) : match.start()]
        if re.search(r"<a\s+href=[\"']?$", before, re.IGNORECASE):
            continue
        found.append(match.group(0))
    return found


def rewrite_index(html: str, available: set[str]) -> tuple[str, list[dict[str, str]]]:
    """``html`` made to request nothing off the machine and no file missing from
    ``available``, and the list of what was removed (``removed`` snippet and ``reason``)."""
    changes: list[dict[str, str]] = []

    def link(match: re.Match[str]) -> str:
        tag = match.group(0)
        href = _HREF.search(tag)
        target = href.group(1) if href else ""
        if target.startswith(("http://", "https://", "//")):
            reason = "an off-machine resource (Google Fonts); the page uses the system font"
        elif target and not local_references(tag) <= available:
            reason = "a file rerun's web-viewer server does not have (404)"
        else:
            return tag
        changes.append({"removed": " ".join(tag.split()), "reason": reason})
        return ""

    html = _LINK_TAG.sub(link, html)

    def analytics(match: re.Match[str]) -> str:
        changes.append(
            {
                "removed": " ".join(match.group(0).split()),
                "reason": "an analytics script injected only when hosted at app.rerun.io",
            }
        )
        return ""

    html = _HOSTED_ANALYTICS.sub(analytics, html)
    head = html.find("<head>")
    if head < 0:
        raise ValueError("the viewer's index.html has no <head>")
    at = head + len("<head>")
    html = html[:at] + "\n" + OFFSITE_GUARD + html[at:]
    changes.append(
        {
            "added": "a script first in <head>",
            "reason": "the viewer's requests to other hosts (telemetry, a release check) are "
            "answered in the page with an empty 204 and never leave the machine",
        }
    )
    return html, changes


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary name beside ``path``, fsync, rename it to ``path``."""
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.part")
    try:
        with tmp.open("wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def _fsync_dir(directory: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def installed_rerun_version() -> str | None:
    """The installed ``rerun-sdk`` distribution's version, or None; does not import rerun."""
    from importlib import metadata

    try:
        return metadata.version("rerun-sdk")
    except metadata.PackageNotFoundError:
        return None


def _require_rerun() -> None:
    version = installed_rerun_version()
    if version is None:
        raise MissingExtraError(
            "the rerun web viewer needs rerun-sdk, which is not installed: "
            f"pip install 'bowlrec[rerun]' (rerun-sdk=={VIEWER_VERSION})"
        )
    if version != VIEWER_VERSION:
        raise UnavailableError(
            f"the rerun web viewer needs rerun-sdk {VIEWER_VERSION}, but {version} is "
            f"installed: pip install 'rerun-sdk=={VIEWER_VERSION}'"
        )


@contextlib.contextmanager
def _file_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``path`` (created if missing) for the block."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def _dir_lock(directory: Path) -> threading.Lock:
    with _DIR_LOCKS_GUARD:
        return _DIR_LOCKS.setdefault(directory, threading.Lock())


class ViewerAssets:
    """The rerun web viewer's files in a cache directory, extracted from ``rerun-sdk`` on
    first use and checked against ``manifest.json``.

    ``cache_root`` is the directory that holds the files (default
    :func:`default_cache_root`). Safe to share between threads, and between processes that
    use the same directory.
    """

    def __init__(self, cache_root: Path | None = None) -> None:
        self.directory = Path(cache_root) if cache_root is not None else default_cache_root()
        self.directory = self.directory.expanduser().absolute()
        self._lock_path = self.directory.with_name(f".{self.directory.name}.lock")
        self._manifest: dict[str, Any] | None = None

    # -- public ---------------------------------------------------------------------------

    def ensure(self) -> Path:
        """The directory with the viewer's files, extracting them first if they are missing,
        damaged or from another rerun version. The first call in a process checks every
        file's SHA-256; later calls check sizes.

        Raises :class:`~bowlrec.errors.UnavailableError` when the files must be extracted and
        ``rerun-sdk`` is missing, is not :data:`VIEWER_VERSION`, or its server fails.
        """
        self._checked_manifest()
        return self.directory

    def manifest(self) -> dict[str, Any]:
        """The checked ``manifest.json`` (extracting first if needed)."""
        return self._checked_manifest()

    def names(self) -> list[str]:
        """The names of the files served, sorted."""
        return sorted(self.manifest()["files"])

    def path(self, name: str) -> Path:
        """The file for the request path ``name`` (``re_viewer.js``). Every file's size is
        checked first, and the files are extracted again when one does not match.

        Raises :class:`~bowlrec.errors.NotFoundError` for a name that is not a file of the
        viewer (``manifest.json``, ``sw.js``, ``../x``, ``nope``).
        """
        if not _SAFE_NAME.fullmatch(name) or name not in self.manifest()["files"]:
            raise NotFoundError(f"the rerun web viewer has no file {name!r}")
        return self.directory / name

    @staticmethod
    def media_type(name: str) -> str:
        """The ``Content-Type`` for a viewer file named ``name``."""
        return _MEDIA_TYPES.get(Path(name).suffix.lower(), "application/octet-stream")

    # -- checking -------------------------------------------------------------------------

    def _checked_manifest(self) -> dict[str, Any]:
        """What :meth:`ensure` does; returns the manifest it checked."""
        with _dir_lock(self.directory):
            known = self._manifest
            if known is not None and self._sizes_match(known):
                return known
            manifest = self._read_valid(full=self.directory not in _VERIFIED)
            if manifest is None:
                with _file_lock(self._lock_path):
                    manifest = self._read_valid(full=True)
                    if manifest is None:
                        manifest = self._extract()
            _VERIFIED.add(self.directory)
            self._manifest = manifest
            return manifest

    def _sizes_match(self, manifest: dict[str, Any]) -> bool:
        for name, entry in manifest["files"].items():
            try:
                if (self.directory / name).stat().st_size != entry["size"]:
                    return False
            except OSError:
                return False
        return True

    def _read_valid(self, *, full: bool) -> dict[str, Any] | None:
        """The manifest when it is for :data:`VIEWER_VERSION` and every file it lists has its
        size (and, when ``full``, its SHA-256); otherwise None."""
        try:
            manifest = json.loads((self.directory / MANIFEST_NAME).read_text("utf-8"))
            if (
                manifest.get("format") != MANIFEST_FORMAT
                or manifest.get("rerun_version") != VIEWER_VERSION
                or manifest.get("guard_sha256") != GUARD_SHA256
                or not set(REQUIRED_FILES) <= set(manifest["files"])
            ):
                return None
            for name, entry in manifest["files"].items():
                if not _SAFE_NAME.fullmatch(name) or name == MANIFEST_NAME:
                    return None
                path = self.directory / name
                if path.stat().st_size != entry["size"]:
                    return None
                if full and _sha256(path) != entry["sha256"]:
                    return None
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return None
        return manifest  # type: ignore[no-any-return]

    # -- extraction -----------------------------------------------------------------------

    def _extract(self) -> dict[str, Any]:
        """Download the files into a staging directory and rename it into place. The caller
        holds the file lock."""
        _require_rerun()
        parent = self.directory.parent
        parent.mkdir(parents=True, exist_ok=True)
        for stale in parent.glob(f".{self.directory.name}.*.part"):
            shutil.rmtree(stale, ignore_errors=True)
        for stale in parent.glob(f".{self.directory.name}.*.old"):
            shutil.rmtree(stale, ignore_errors=True)
        staging = parent / f".{self.directory.name}.{uuid.uuid4().hex[:8]}.part"
        staging.mkdir()
        try:
            manifest = self._fill(staging)
            old = parent / f".{self.directory.name}.{uuid.uuid4().hex[:8]}.old"
            if self.directory.exists():
                os.replace(self.directory, old)
            os.replace(staging, self.directory)
            _fsync_dir(parent)
            shutil.rmtree(old, ignore_errors=True)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        return manifest

    def _fill(self, staging: Path) -> dict[str, Any]:
        """Run the download child into ``staging``, rewrite ``index.html``, write the
        manifest; return it."""
        started = time.monotonic()
        report = _run_child(staging)
        fetched: dict[str, int] = report["fetched"]
        missing = set(REQUIRED_FILES) - set(fetched)
        if missing:
            raise UnavailableError(
                f"rerun's web-viewer server did not serve {', '.join(sorted(missing))}"
            )
        if (staging / "re_viewer_bg.wasm").read_bytes()[:4] != b"\0asm":
            raise UnavailableError(
                "rerun's web-viewer server served a re_viewer_bg.wasm that is not wasm"
            )

        index = staging / "index.html"
        original = index.read_bytes()
        html, changes = rewrite_index(original.decode("utf-8"), set(fetched))
        remote = remote_fetches(html)
        if remote:
            raise UnavailableError(
                f"the rerun {VIEWER_VERSION} web viewer's index.html requests {remote[0]}, "
                "which bowlrec does not know how to remove"
            )
        _write_atomic(index, html.encode("utf-8"))

        files = {
            name: {"size": (staging / name).stat().st_size, "sha256": _sha256(staging / name)}
            for name in sorted(fetched)
        }
        manifest: dict[str, Any] = {
            "format": MANIFEST_FORMAT,
            "rerun_version": VIEWER_VERSION,
            "guard_sha256": GUARD_SHA256,
            "source": "rerun.serve_web_viewer (rerun-sdk, in a child process)",
            "extracted_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "extract_seconds": round(time.monotonic() - started, 2),
            "files": files,
            "rewritten": {
                "index.html": {
                    "original_size": len(original),
                    "original_sha256": hashlib.sha256(original).hexdigest(),
                    "changes": changes,
                }
            },
            "not_found_on_rerun_server": sorted(report["missing"]),
            "not_served": NOT_SERVED,
        }
        _write_atomic(
            staging / MANIFEST_NAME, (json.dumps(manifest, indent=2) + "\n").encode("utf-8")
        )
        _fsync_dir(staging)
        return manifest


def _run_child(staging: Path) -> dict[str, Any]:
    """Run :func:`_child_main` in ``sys.executable`` and return its report."""
    package_root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    env.setdefault("RUST_LOG", "error")
    code = "import sys; from bowlrec.web.viewer_assets import _child_main; _child_main(sys.argv[1])"
    try:
        proc = subprocess.run(
            [sys.executable, "-c", code, str(staging)],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=_EXTRACT_TIMEOUT_S,
            env=env,
        )
    except subprocess.TimeoutExpired as err:
        raise UnavailableError(
            f"extracting the rerun web viewer took over {_EXTRACT_TIMEOUT_S:.0f} s"
        ) from err
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        detail = (proc.stderr.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
        raise UnavailableError(f"could not extract the rerun web viewer: {detail}")
    report: dict[str, Any] = json.loads(lines[-1])
    return report


def _child_main(dest: str) -> None:
    """In the child process: serve rerun's web viewer on a free loopback port, download every
    file its page loads into ``dest`` (each written atomically), print a JSON report
    (``fetched``: name to size, ``missing``: names the server answered 404) and exit."""
    import socket
    import urllib.error
    import urllib.request

    import rerun

    directory = Path(dest)
    base = ""
    for _attempt in range(5):
        with socket.socket() as sock:
            sock.bind(("", 0))  # rerun binds 0.0.0.0: the port must be free there
            port = sock.getsockname()[1]
        try:
            rerun.serve_web_viewer(web_port=port, open_browser=False)
        except Exception:  # the port was taken meanwhile: another one
            continue
        base = f"http://127.0.0.1:{port}/"
        break
    if not base:
        raise SystemExit("rerun.serve_web_viewer did not start")

    def get(name: str) -> bytes | None:
        try:
            with urllib.request.urlopen(base + name, timeout=60) as response:
                data: bytes = response.read()
                return data
        except urllib.error.HTTPError as err:
            if err.code == 404:
                return None
            raise

    deadline = time.monotonic() + _SERVER_START_TIMEOUT_S
    while True:
        try:
            index = get("index.html")
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)

    fetched: dict[str, int] = {}
    missing: list[str] = []
    pending = ["index.html"]
    while pending:
        name = pending.pop(0)
        if name in fetched or name in missing or name in NOT_SERVED:
            continue
        if not _SAFE_NAME.fullmatch(name) or name == MANIFEST_NAME:
            missing.append(name)
            continue
        data = index if name == "index.html" else get(name)
        if data is None:
            missing.append(name)
            continue
        _write_atomic(directory / name, data)
        fetched[name] = len(data)
        if name.endswith((".html", ".js")):
            pending.extend(sorted(local_references(data.decode("utf-8", "replace"))))
    print(json.dumps({"fetched": fetched, "missing": missing}), flush=True)
    sys.stderr.flush()
    os._exit(0)  # do not wait for rerun's server thread
