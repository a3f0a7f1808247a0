"""Pure-ASGI guard in front of everything the brain serves (REST, Socket.IO, the UI):

- **Host** must be one of ``api.trusted_hosts`` (a DNS-rebinding page reaches the brain under
  its own name, e.g. ``evil.example:8000``, so the Host header gives it away);
- **Origin**, when a browser sends one, must be this site (its host equals the Host header) or
  an exact ``api.cors_origins`` entry, for every state-changing request and WebSocket;
  requests without an Origin (machines: the signed ``/api/agent/events``, curl) pass;
- with operator login **off**, a request that came through a proxy (``Forwarded``,
  ``X-Forwarded-For``, ``X-Real-IP``) is refused: without login only the loopback bind
  protects the brain, and a proxy on the host would open it to the network.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any
from urllib.parse import urlsplit

import structlog

logger = structlog.get_logger(__name__)

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
PROXY_HEADERS = (b"forwarded", b"x-forwarded-for", b"x-real-ip", b"x-forwarded-host")


def host_name(host_header: str) -> str:
    """``example.org:8000`` → ``example.org``; ``[::1]:8000`` → ``::1`` (lower case)."""
    host = host_header.strip().lower()
    if host.startswith("["):
        return host[1 : host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


class RequestGuard:
    def __init__(
        self,
        app: Any,
        *,
        trusted_hosts: Iterable[str],
        allowed_origins: Iterable[str] = (),
        login_enabled: bool,
    ) -> None:
        self.app = app
        hosts = {host_name(h) for h in trusted_hosts}
        self.any_host = "*" in hosts
        self.trusted_hosts = frozenset(hosts - {"*"})
        self.allowed_origins = frozenset(allowed_origins)
        self.login_enabled = login_enabled

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        reason = self.refusal(scope)
        if reason is None:
            await self.app(scope, receive, send)
            return
        client = scope.get("client") or ("?", 0)
        logger.warning("request_refused", reason=reason, path=scope.get("path"), client=client[0])
        await _refuse(scope, receive, send, reason)

    def refusal(self, scope: Any) -> str | None:
        """Why this request is refused, or None."""
        headers: dict[bytes, str] = {}
        for key, value in scope.get("headers", []):
            headers.setdefault(key.lower(), value.decode("latin-1"))
        host = headers.get(b"host", "")
        if not self.any_host and host_name(host) not in self.trusted_hosts:
            return "untrusted_host"
        if not self.login_enabled and any(h in headers for h in PROXY_HEADERS):
            return "proxied_without_login"
        origin = headers.get(b"origin")
        changes_state = scope["type"] == "websocket" or scope.get("method") not in SAFE_METHODS
        if origin is not None and changes_state and not self.origin_allowed(origin, host):
            return "foreign_origin"
        return None

    def origin_allowed(self, origin: str, host: str) -> bool:
        if origin in self.allowed_origins:
            return True
        netloc = urlsplit(origin).netloc.lower()
        return bool(netloc) and netloc == host.strip().lower()


MESSAGES = {
    "untrusted_host": "this host name is not served here (api.trusted_hosts)",
    "proxied_without_login": (
        "requests through a proxy are refused while operator login is off "
        "(enable auth, RVC_DEPLOYMENT=robot)"
    ),
    "foreign_origin": "cross-origin requests are refused (api.cors_origins)",
}


async def _refuse(scope: Any, receive: Any, send: Any, reason: str) -> None:
    if scope["type"] == "websocket":
        await receive()  # websocket.connect
        await send({"type": "websocket.close", "code": 4403})
        return
    body = json.dumps({"detail": MESSAGES[reason], "reason": reason}).encode()
    status = 400 if reason == "untrusted_host" else 403
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"cache-control", b"no-store"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
