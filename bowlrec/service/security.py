"""Who may talk to the service: the bearer token, cookie sessions, the Host allow-list and the
cross-site (Origin / Sec-Fetch-Site) check. See ``docs/service.md`` for the model.

- A request that carries the server's token (``Authorization: Bearer <token>``) is trusted as it
  is: no Host or Origin check (scripts and curl keep working whatever name they use).
- Every other request (a browser's: cookie session, or any request to a server without a
  token) must name an allowed host in ``Host`` (loopback names, the bound IP, ``serve
  --allowed-host``), else 400: this defeats DNS rebinding, where a page of another site reaches
  the server under the site's own name.
- State-changing requests (POST, PUT, PATCH, DELETE) among those must also come from the
  server's own pages: ``Sec-Fetch-Site``, when sent, is ``same-origin`` or ``none``, and
  ``Origin``, when sent, is the server's own origin (scheme and Host); else 403. Requests
  with neither header (curl, scripts) pass.
- ``POST /session`` with the token (bearer header or ``{"token": ...}``) opens a cookie session
  (an HttpOnly, SameSite=Strict cookie holding a random ID; the server keeps the ID's hash and
  expiry in memory), which authenticates the requests a browser cannot add a header to
  (iframes, images, download links, EventSource). ``DELETE /session`` closes it.

Tokens and session IDs are compared in constant time (:func:`hmac.compare_digest`).
"""

from __future__ import annotations

import hashlib
import hmac
import json
import secrets
import shlex
import threading
import time
from collections.abc import Callable, Iterable
from urllib.parse import urlsplit

from starlette.datastructures import Headers
from starlette.types import ASGIApp, Receive, Scope, Send

from .names import host_name, is_loopback_name

__all__ = [
    "COOKIE_NAME",
    "DEFAULT_SESSION_TTL_S",
    "SecurityMiddleware",
    "SessionStore",
    "bearer_matches",
]

#: the session cookie's name
COOKIE_NAME = "bowlrec_session"
#: how long a cookie session lasts (seconds): 12 hours
DEFAULT_SESSION_TTL_S = 12 * 3600.0
#: open sessions kept at most (the oldest is dropped beyond this)
MAX_SESSIONS = 1000
#: methods that change state: these get the cross-site check
UNSAFE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
_DEFAULT_PORTS = {"http": 80, "https": 443, "ws": 80, "wss": 443}


# -- names ---------------------------------------------------------------------------------------


def bearer_matches(authorization: str | None, token: str | None) -> bool:
    """True when the header is ``Bearer <token>`` with the server's token (constant time)."""
    if token is None or not authorization:
        return False
    scheme, _, given = authorization.partition(" ")
    if scheme.lower() != "bearer":
        return False
    return hmac.compare_digest(given.strip().encode(), token.encode())


def token_matches(given: str, token: str | None) -> bool:
    return token is not None and hmac.compare_digest(given.encode(), token.encode())


# -- sessions ------------------------------------------------------------------------------------


class SessionStore:
    """Cookie sessions in memory: the SHA-256 of each session ID and its expiry. ``ttl_s``: a
    session's lifetime in s; ``clock``: the time now as a UNIX time in s."""

    def __init__(
        self,
        ttl_s: float = DEFAULT_SESSION_TTL_S,
        max_sessions: int = MAX_SESSIONS,
        clock: Callable[[], float] = time.time,
    ):
        self.ttl_s = ttl_s
        self.max_sessions = max_sessions
        self.clock = clock
        self._expiry: dict[str, float] = {}  # sha256(id) -> clock() of expiry
        self._mutex = threading.Lock()

    @staticmethod
    def _key(session_id: str) -> str:
        return hashlib.sha256(session_id.encode(errors="surrogateescape")).hexdigest()

    def open(self) -> tuple[str, float]:
        """A new session: (its ID for the cookie, its expiry as a UNIX time)."""
        session_id = secrets.token_urlsafe(32)
        expires = self.clock() + self.ttl_s
        with self._mutex:
            self._purge()
            while len(self._expiry) >= self.max_sessions:
                oldest = min(self._expiry, key=self._expiry.__getitem__)
                del self._expiry[oldest]
            self._expiry[self._key(session_id)] = expires
        return session_id, expires

    def valid(self, session_id: str | None) -> bool:
        if not session_id:
            return False
        with self._mutex:
            expires = self._expiry.get(self._key(session_id))
            if expires is None:
                return False
            if expires <= self.clock():
                del self._expiry[self._key(session_id)]
                return False
            return True

    def close(self, session_id: str | None) -> bool:
        """Forget the session; True if it was open."""
        if not session_id:
            return False
        with self._mutex:
            return self._expiry.pop(self._key(session_id), None) is not None

    def __len__(self) -> int:
        with self._mutex:
            self._purge()
            return len(self._expiry)

    def _purge(self) -> None:
        now = self.clock()
        for key in [k for k, t in self._expiry.items() if t <= now]:
            del self._expiry[key]


# -- the middleware ------------------------------------------------------------------------------


class SecurityMiddleware:
    """The Host allow-list and the cross-site check (pure ASGI, before anything else runs).

    ``token``: the server's token (None: a server without one); ``allowed_hosts``: names
    allowed besides the loopback ones (``serve --allowed-host`` and the bound IP).
    """

    def __init__(
        self, app: ASGIApp, *, token: str | None, allowed_hosts: Iterable[str] = ()
    ) -> None:
        self.app = app
        self.token = token
        allowed: set[str] = set()
        for entry in allowed_hosts:
            name = host_name(entry)
            if name is None:
                raise ValueError(f"not a host name: {entry!r}")
            allowed.add(name)
        self.allowed_hosts = frozenset(allowed)

    def allows_host(self, name: str) -> bool:
        return is_loopback_name(name) or name in self.allowed_hosts

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        if bearer_matches(headers.get("authorization"), self.token):
            await self.app(scope, receive, send)  # a script holding the token: trusted
            return
        host = headers.get("host")
        if host is not None:
            name = host_name(host)
            if name is None or not self.allows_host(name):
                shown = (name or host)[:100]
                await _refuse(
                    send,
                    400,
                    f"host {shown!r} is not allowed (DNS-rebinding protection): start the "
                    f"server with --allowed-host {_cli_word(shown)} to allow it, or send "
                    "the bearer token",
                )
                return
        if scope["method"] in UNSAFE_METHODS:
            refusal = _cross_site(scope, headers)
            if refusal is not None:
                await _refuse(send, 403, refusal)
                return
        await self.app(scope, receive, send)


def _cross_site(scope: Scope, headers: Headers) -> str | None:
    """Why a state-changing request is refused as cross-site (None: it is not)."""
    fetch_site = headers.get("sec-fetch-site")
    if fetch_site is not None and fetch_site.strip().lower() not in ("same-origin", "none"):
        return (
            f"cross-site request refused (Sec-Fetch-Site: {fetch_site.strip()[:40]}); "
            "state-changing requests must come from this server's pages or carry the token"
        )
    origin = headers.get("origin")
    if origin is not None and not _same_origin(origin, scope, headers.get("host")):
        return (
            f"cross-site request refused (Origin {origin.strip()[:100]} is not this "
            "server's origin); state-changing requests must come from this server's pages or "
            "carry the token"
        )
    return None


def _same_origin(origin: str, scope: Scope, host: str | None) -> bool:
    scheme = str(scope.get("scheme", "http")).lower()
    if host is None:
        return False
    try:
        parts = urlsplit(origin.strip())
        origin_port = parts.port
    except ValueError:
        return False
    if parts.scheme.lower() != scheme or parts.hostname is None:
        return False
    origin_name = host_name(parts.hostname)
    own_name = host_name(host)
    own_port_text = _port_of(host)
    own_port = int(own_port_text) if own_port_text else _DEFAULT_PORTS.get(scheme)
    if origin_port is None:
        origin_port = _DEFAULT_PORTS.get(scheme)
    return origin_name is not None and origin_name == own_name and origin_port == own_port


def _port_of(host: str) -> str:
    host = host.strip()
    if host.startswith("["):
        rest = host[host.find("]") + 1 :]
        return rest[1:] if rest.startswith(":") else ""
    _, _, port = host.partition(":")
    return port


def _cli_word(name: str) -> str:
    """``name`` as one shell word (quoted only when needed)."""

    return shlex.quote(name)


async def _refuse(send: Send, status: int, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
