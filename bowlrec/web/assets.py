"""The files the pages load, all from this server: the pages' own CSS and JavaScript
(``/static``), Swagger UI and ReDoc for ``/docs`` and ``/redoc`` (``/static/apidocs``, from the
``fastapi-offline`` package: Swagger UI 5, which reads OpenAPI 3.1) and the rerun web viewer
(``/viewer``, :mod:`bowlrec.web.viewer_assets`). None of them needs the token: they are the
same for every archive and hold no data."""

from __future__ import annotations

import logging
import threading
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

from bowlrec.errors import BowlrecError

from .viewer_assets import ViewerAssets

__all__ = ["STATIC_DIR", "mount", "prepare_viewer_in_background"]

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).parent / "static"
#: the viewer's pages may run their own inline scripts and WebAssembly and connect only to
#: this server (the .rrd files); only this server's pages may frame them
VIEWER_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; script-src 'self' 'unsafe-inline' 'wasm-unsafe-eval'; "
        "style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; font-src 'self' data:; "
        "connect-src 'self' data: blob:; worker-src 'self' blob:; frame-ancestors 'self'"
    ),
    "X-Content-Type-Options": "nosniff",
}


def apidocs_dir() -> Path | None:
    """The API documentation's files (``swagger-ui-bundle.js``, ``swagger-ui.css``,
    ``redoc.standalone.js``), or None when the ``fastapi-offline`` package is missing
    (``/docs`` then says how to install it)."""
    try:
        import fastapi_offline
    except ImportError:
        return None
    return Path(fastapi_offline.__file__).parent / "static"


def _no_apidocs() -> HTMLResponse:
    return HTMLResponse(
        "<p>The API documentation's files are not installed: <code>pip install "
        "'bowlrec[service]'</code>. The API description is at "
        '<a href="/openapi.json">/openapi.json</a>.</p>',
        status_code=501,
    )


def mount(app: FastAPI) -> None:
    """Add ``/static``, ``/static/apidocs``, ``/docs``, ``/redoc`` and ``/viewer/{file}`` to
    ``app``."""
    apidocs = apidocs_dir()
    if apidocs is not None:
        app.mount("/static/apidocs", StaticFiles(directory=apidocs), name="apidocs")
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    openapi_url = app.openapi_url or "/openapi.json"

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        if apidocs is None:
            return _no_apidocs()
        return get_swagger_ui_html(
            openapi_url=openapi_url,
            title="bowlrec API",
            swagger_js_url="/static/apidocs/swagger-ui-bundle.js",
            swagger_css_url="/static/apidocs/swagger-ui.css",
            swagger_favicon_url="/static/favicon.svg",
        )

    @app.get("/redoc", include_in_schema=False)
    def redoc() -> HTMLResponse:
        if apidocs is None:
            return _no_apidocs()
        return get_redoc_html(
            openapi_url=openapi_url,
            title="bowlrec API",
            redoc_js_url="/static/apidocs/redoc.standalone.js",
            redoc_favicon_url="/static/favicon.svg",
            with_google_fonts=False,
        )

    @app.get("/viewer/{name:path}", include_in_schema=False)
    def viewer_file(request: Request, name: str) -> FileResponse:
        """A file of the rerun web viewer (``index.html``, ``re_viewer.js``, the wasm...)."""
        viewer: ViewerAssets = request.app.state.bowlrec.viewer
        path = viewer.path(name or "index.html")
        return FileResponse(
            path,
            media_type=viewer.media_type(path.name),
            headers={"Cache-Control": "public, max-age=86400", **VIEWER_HEADERS},
        )


def prepare_viewer_in_background(viewer: ViewerAssets) -> threading.Thread:
    """Extract the viewer's files now (once per machine and rerun version) in a thread, so
    that the first run page does not wait for it; a failure is logged, and the viewer's
    route reports it when asked."""

    def work() -> None:
        try:
            viewer.ensure()
        except BowlrecError as err:
            log.info("the rerun web viewer is not available: %s", err)
        except Exception:  # logged; /viewer retries and answers with the error
            log.exception("could not prepare the rerun web viewer")

    thread = threading.Thread(target=work, name="bowlrec-viewer-assets", daemon=True)
    thread.start()
    return thread
