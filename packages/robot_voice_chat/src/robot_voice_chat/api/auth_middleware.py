"""Pure-ASGI gate: every HTTP/WebSocket request needs an operator session, with few exceptions.

Public: liveness/readiness, the HMAC-signed event ingress (machines, own signature check),
the login/logout/me routes, and the UI's static shell (it holds no robot data and must load
to show the login page). Everything else under ``/api``, ``/socket.io`` and the API docs
needs a session; without one HTTP gets 401 and a WebSocket is closed before accept.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from http.cookies import SimpleCookie
from typing import Any

import structlog

from robot_voice_chat.api.auth import OperatorAuth
from robot_voice_chat.operator import acting_operator

logger = structlog.get_logger(__name__)

PUBLIC_PATHS = frozenset(
    {
        "/api/livez",
        "/api/readyz",
        "/api/agent/events",
        "/api/auth/login",
        "/api/auth/logout",
        "/api/auth/me",
    }
)
PROTECTED_PREFIXES = ("/api/", "/socket.io", "/docs", "/redoc", "/openapi.json")


def requires_login(path: str) -> bool:
    normalized = "/" + "/".join(p for p in path.split("/") if p)
    if normalized in PUBLIC_PATHS:
        return False
    return normalized == "/api" or any(
        normalized.startswith(p) or normalized + "/" == p for p in PROTECTED_PREFIXES
    )


def session_cookie(scope: Mapping[str, Any], name: str) -> str | None:
    for key, value in scope.get("headers", []):
        if key == b"cookie":
            found = cookie_value(value.decode("latin-1"), name)
            if found is not None:
                return found
    return None


def cookie_value(header: str, name: str) -> str | None:
    """``name``'s value in one Cookie header (None when absent or the header is malformed)."""
    jar: SimpleCookie = SimpleCookie()
    try:
        jar.load(header)
    except Exception:  # a malformed Cookie header is simply "no session"
        return None
    return jar[name].value if name in jar else None


class OperatorAuthMiddleware:
    def __init__(self, app: Any, auth: OperatorAuth) -> None:
        self.app = app
        self.auth = auth

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        operator = self.auth.operator_for(session_cookie(scope, self.auth.config.cookie_name))
        if operator is None and requires_login(scope.get("path", "")):
            await _refuse(scope, receive, send)
            return
        with acting_operator(operator):
            await self.app(scope, receive, send)


async def _refuse(scope: Any, receive: Any, send: Any) -> None:
    client = scope.get("client") or ("?", 0)
    logger.info("auth_required", path=scope.get("path"), client=client[0], kind=scope["type"])
    if scope["type"] == "websocket":
        await receive()  # websocket.connect
        await send({"type": "websocket.close", "code": 4401})
        return
    body = json.dumps({"detail": "login required"}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": 401,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"cache-control", b"no-store"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
