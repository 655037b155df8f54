"""The HTTP service (``bowlrec serve``): submit scenes and jobs, query runs, download their
files and manage the ball library over HTTP. Needs the ``service`` extra (FastAPI, uvicorn).

:func:`create_app` builds the FastAPI application for one archive; this package imports FastAPI
only when it is called.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fastapi import FastAPI

__all__ = ["create_app"]


def create_app(archive_dir: Any, token: str | None = None, **options: Any) -> FastAPI:
    """See :func:`bowlrec.service.app.create_app`."""
    from .app import create_app as _create_app

    return _create_app(archive_dir, token, **options)
