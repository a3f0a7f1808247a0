"""Request bodies have a size limit before anything reads them, and a refused body is never
sent back (issue 31: a 200 MB login came back as a 422 carrying 200 MiB; RSS 250 → 1044 MiB).

- ``BodyLimitMiddleware`` (pure ASGI): a declared ``Content-Length`` over the limit is a 413
  at once, unread; a body that streams past it is cut off with a 413 when the limit is crossed.
  ``api.max_body_bytes`` by default; some paths have their own (audio turns, the signed ingress).
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


def _content_length(scope: Any) -> int | None:
    for key, value in scope.get("headers", []):
        if key.lower() == b"content-length":
            text = value.decode("latin-1").strip()
            return int(text) if text.isdigit() else None
    return None


async def _too_large(scope: Any, send: Any, limit: int) -> None:
    logger.warning("request_too_large", path=scope.get("path"), limit=limit)
    body = json.dumps({"detail": f"the request body is larger than {limit} bytes"}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": 413,
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
