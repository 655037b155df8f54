"""``bowlrec serve``: the HTTP service (FastAPI + uvicorn, imported only when it runs)."""

from __future__ import annotations

import ipaddress
import os
from typing import Annotated

import typer

from ._app import app
from ._common import ArchiveOption, fail, open_archive

DEFAULT_TOKEN_ENV = "BOWLREC_TOKEN"


def is_loopback(host: str) -> bool:
    """True for localhost, 127.0.0.0/8 and ::1 (the only hosts served without a token)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


@app.command("serve")
def serve(
    archive: ArchiveOption = None,
    host: Annotated[
        str, typer.Option(help="Interface to bind; anything but loopback needs a token.")
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="TCP port.", min=0, max=65535)] = 8000,
    token_env: Annotated[
        str,
        typer.Option(
            help="Environment variable holding the bearer token; when it is set (non-empty), "
            "every request except /health and /docs needs 'Authorization: Bearer <token>'."
        ),
    ] = DEFAULT_TOKEN_ENV,
    insecure: Annotated[
        bool,
        typer.Option("--insecure", help="Allow a non-loopback host without a token."),
    ] = False,
    job_workers: Annotated[
        int,
        typer.Option(
            help="Processes that simulate jobs: 0 = in the server process (default), N = a "
            "local pool of N.",
            min=0,
        ),
    ] = 0,
    scheduler: Annotated[
        str | None,
        typer.Option(
            envvar="BOWLREC_SCHEDULER",
            help="Run jobs on this dask.distributed scheduler (tcp://HOST:PORT; needs "
            "bowlrec\\[dask]); default: 'scheduler' in the config file, if any.",
        ),
    ] = None,
    log_level: Annotated[
        str, typer.Option(help="uvicorn log level: critical|error|warning|info|debug.")
    ] = "info",
) -> None:
    """Serve the archive over HTTP (API docs at http://HOST:PORT/docs).

    Submit scenes and jobs, list and download runs, manage the ball library.
    """
    token = os.environ.get(token_env) or None
    if token is None and not is_loopback(host) and not insecure:
        fail(
            f"refusing to serve {host} without a token: set ${token_env} (or choose another "
            "variable with --token-env), bind to 127.0.0.1, or pass --insecure"
        )
    try:
        import uvicorn

        from bowlrec.service.app import create_app
    except ImportError as err:
        fail(f"bowlrec serve needs the service extra: pip install 'bowlrec[service]' ({err})")
    from bowlrec.service.jobs import JobsLockedError

    store = open_archive(archive)
    try:
        if scheduler is None:
            from bowlrec.archive.location import config_value

            scheduler = config_value("scheduler")
        application = create_app(store.root, token, job_workers=job_workers, scheduler=scheduler)
    except JobsLockedError as err:
        fail(str(err))
    auth = f"token from ${token_env}" if token else "no token"
    typer.echo(
        f"bowlrec: serving {store.root} on http://{host}:{port} ({auth}); docs at /docs", err=True
    )
    uvicorn.run(application, host=host, port=port, log_level=log_level)
