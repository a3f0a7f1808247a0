"""Request bodies have a size limit before anything reads them, and a refused body is never
sent back (issue 31: a 200 MB login came back as a 422 carrying 200 MiB; RSS 250 → 1044 MiB).

- ``BodyLimitMiddleware`` (pure ASGI): a declared ``Content-Length`` over the limit is a 413
  at once, unread; a body that streams past it is cut off with a 413 when the limit is crossed.
  ``api.max_body_bytes`` by default; some paths have their own (audio turns, the signed ingress).
- ``SocketIOBodyLimit`` (pure ASGI, in front of Socket.IO, which FastAPI's middleware never
  sees; issue 35: a logged-in 5 MB long-polling POST went unanswered for 60 s and then held
  the brain's stop 13.5 s): a POST under ``/socket.io`` whose declared ``Content-Length`` is
  over the limit is a 413 at once, one without a ``Content-Length`` a 411 (engine.io clients
  always send one). The refused body is read and dropped first, up to ``drain_limit`` bytes,
  because an HTTP/1.1 client writes its whole body before it reads the answer, and a server
  that answers without reading leaves it stuck writing (or reset) instead of told.
- :func:`validation_error`: FastAPI's 422 without ``input``/``ctx`` (they echo the body, and a
  password typed into the wrong field with it).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import structlog
from fastapi import Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException

logger = structlog.get_logger(__name__)
_WITH_BODY = frozenset({"POST", "PUT", "PATCH"})


class BodyLimitMiddleware:
    def __init__(
        self,
        app: Any,
        *,
        default: int,
        limits: Mapping[str, int] | None = None,
        exempt_paths: frozenset[str] = frozenset(),
    ) -> None:
        self.app = app
        self.default = default
        self.limits = dict(limits or {})
        self.exempt_paths = exempt_paths  # routes that read (and refuse) their own bodies

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        path = scope.get("path", "")
        if (
            scope["type"] != "http"
            or scope.get("method") not in _WITH_BODY
            or path in self.exempt_paths
        ):
            await self.app(scope, receive, send)
            return
        limit = self.limits.get(path, self.default)
        declared = _content_length(scope)
        if declared is not None and declared > limit:
            await _too_large(scope, send, limit)
            return
        seen = 0

        async def limited() -> Any:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    logger.warning("request_too_large", path=scope.get("path"), limit=limit)
                    raise HTTPException(413, f"the request body is larger than {limit} bytes")
            return message

        await self.app(scope, limited, send)


DRAIN_LIMIT = 16 * 1024 * 1024
"""A refused body is read and dropped up to this many bytes before the answer (see above);
past it the connection is answered and closed unread."""


class SocketIOBodyLimit:
    def __init__(
        self, app: Any, *, limit: int, prefix: str = "/socket.io", drain_limit: int = DRAIN_LIMIT
    ) -> None:
        self.app = app
        self.limit = limit
        self.prefix = prefix
        self.drain_limit = drain_limit

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if (
            scope["type"] != "http"
            or scope.get("method") not in _WITH_BODY
            or not scope.get("path", "").startswith(self.prefix)
        ):
            await self.app(scope, receive, send)
            return
        declared = _content_length(scope)
        if declared is not None and declared <= self.limit:
            await self.app(scope, receive, send)
            return
        await _drain(receive, self.drain_limit)
        if declared is None:
            logger.warning("request_length_required", path=scope.get("path"))
            await _refuse(send, 411, "a Socket.IO POST needs a Content-Length")
            return
        await _too_large(scope, send, self.limit)


async def _drain(receive: Any, limit: int) -> None:
    """Read and drop the request body (at most ``limit`` bytes, then stop reading)."""
    seen = 0
    while seen <= limit:
        message = await receive()
        if message["type"] != "http.request":
            return
        seen += len(message.get("body", b""))
        if not message.get("more_body"):
            return


def _content_length(scope: Any) -> int | None:
    for key, value in scope.get("headers", []):
        if key.lower() == b"content-length":
            text = value.decode("latin-1").strip()
            return int(text) if text.isdigit() else None
    return None


async def _too_large(scope: Any, send: Any, limit: int) -> None:
    logger.warning("request_too_large", path=scope.get("path"), limit=limit)
    await _refuse(send, 413, f"the request body is larger than {limit} bytes")


async def _refuse(send: Any, status: int, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


async def validation_error(_: Request, exc: Exception) -> JSONResponse:
    """422 naming where and what, never the value that was sent."""
    assert isinstance(exc, RequestValidationError)
    errors = [
        {"type": e.get("type"), "loc": list(e.get("loc", ())), "msg": e.get("msg")}
        for e in exc.errors()
    ]
    return JSONResponse({"detail": errors}, status_code=422)
