"""A request body limit (uvicorn has none): a pure ASGI middleware.

A request whose ``Content-Length`` exceeds the limit is answered 413 before any of its body is
read; a body without a length (chunked) is counted as it streams to the application, and once
it passes the limit nothing more is read: the application's ``receive`` raises, and whatever
the application answers is replaced by the 413. The detail is one line:
``request body exceeds the limit of N bytes (serve --max-body-mb)``.
"""

from __future__ import annotations

import json
from typing import Any

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .names import DEFAULT_MAX_BODY_BYTES

__all__ = ["DEFAULT_MAX_BODY_BYTES", "BodyLimitMiddleware", "BodyTooLargeError"]


class BodyTooLargeError(HTTPException):
    """Raised by ``receive`` once the body passed the limit (FastAPI lets HTTPException
    through its body parsing; the middleware answers 413 whatever happens next). An HTTP-level
    signal that never leaves the middleware, so not a :class:`~bowlrec.errors.BowlrecError`."""


def too_large_detail(limit: int) -> str:
    return f"request body exceeds the limit of {limit} bytes (serve --max-body-mb)"


class BodyLimitMiddleware:
    """Answer 413 to HTTP requests whose body is longer than ``max_bytes``."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        if max_bytes < 0:
            raise ValueError("max_bytes must be >= 0")
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.max_bytes
        detail = too_large_detail(limit)
        length = _content_length(scope)
        if length is not None and length > limit:
            await _send_413(send, detail)
            return

        received = 0
        exceeded = False
        response_started = False

        async def limited_receive() -> Message:
            nonlocal received, exceeded
            if exceeded:
                raise BodyTooLargeError(413, detail)
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    exceeded = True
                    raise BodyTooLargeError(413, detail)
            return message

        async def guarded_send(message: Message) -> None:
            nonlocal response_started
            if exceeded:  # the application's own answer to the failed read: ours instead
                if not response_started:
                    response_started = True
                    await _send_413(send, detail)
                return
            if message["type"] == "http.response.start":
                response_started = True
            await send(message)

        try:
            await self.app(scope, limited_receive, guarded_send)
        except Exception:
            if not exceeded:
                raise
            if not response_started:
                response_started = True
                await _send_413(send, detail)


def _content_length(scope: Scope) -> int | None:
    for key, value in scope.get("headers", ()):
        if key == b"content-length":
            try:
                return int(value)
            except ValueError:
                return None  # the server rejects a malformed length itself
    return None


async def _send_413(send: Send, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers: list[tuple[bytes, bytes]] = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        (b"connection", b"close"),
    ]
    start: dict[str, Any] = {"type": "http.response.start", "status": 413, "headers": headers}
    await send(start)
    await send({"type": "http.response.body", "body": body})
