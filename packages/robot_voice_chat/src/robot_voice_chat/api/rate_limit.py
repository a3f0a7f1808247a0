"""Pure-ASGI middleware: ``api.default_rate_limit`` per client address on every HTTP request,
except the signed event ingress (it has its own per-server and per-address limits)."""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any

import structlog

from robot_voice_chat.api.ingress import RateLimit

logger = structlog.get_logger(__name__)


class DefaultRateLimitMiddleware:
    def __init__(self, app: Any, *, limit: str, exempt_paths: Iterable[str] = ()) -> None:
        self.app = app
        self.limit = RateLimit(limit)
        self.exempt_paths = frozenset(exempt_paths)

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope.get("path") in self.exempt_paths:
            await self.app(scope, receive, send)
            return
        client = (scope.get("client") or ("?", 0))[0]
        if self.limit.hit(client):
            await self.app(scope, receive, send)
            return
        logger.warning("rate_limited", client=client, path=scope.get("path"))
        body = json.dumps({"detail": "too many requests; try again in a minute"}).encode()
        await send(
            {
                "type": "http.response.start",
                "status": 429,
                "headers": [
                    (b"content-type", b"application/json"),
                    (b"content-length", str(len(body)).encode()),
                    (b"retry-after", b"60"),
                ],
            }
        )
        await send({"type": "http.response.body", "body": body})
