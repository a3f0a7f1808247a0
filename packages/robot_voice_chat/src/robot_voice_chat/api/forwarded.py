"""Who the client is behind the reverse proxy: ``X-Forwarded-For``/``-Proto`` are believed only
from the proxy (issue 31).

On a robot every local process reaches 127.0.0.1, so a loopback address proves nothing: with
loopback trusted, any of them could send a new ``X-Forwarded-For`` per request and never meet
the login throttle or the rate limit. The proxy therefore talks to the brain over a Unix socket
(``robot-voice-chat --proxy-socket``; only the brain's group, which Caddy joins, may connect),
and forwarded headers are believed from connections over that socket, or from a peer listed in
``auth.trusted_proxies`` (a proxy on another host; empty by default). Everyone else is the
address of their own connection.
"""

from __future__ import annotations

import socket
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from uvicorn.middleware.proxy_headers import ProxyHeadersMiddleware

PROXY_PEER = "reverse-proxy"  # the client of a connection over the proxy socket (no address)
SOCKET_MODE = 0o660  # the brain's user and group (Caddy is added to the group)


def over_unix_socket(scope: dict[str, Any]) -> bool:
    """A connection on a Unix socket: no peer address, the server's "port" is None."""
    server = scope.get("server")
    return scope.get("client") is None and server is not None and server[1] is None


class ForwardedFromProxy:
    """Pure ASGI: applies the forwarded headers of trusted connections only (uvicorn's own
    proxy-header middleware, with the proxy socket as one more trusted peer)."""

    def __init__(self, app: Any, trusted_peers: Iterable[str] = ()) -> None:
        self.app = ProxyHeadersMiddleware(app, trusted_hosts=[*trusted_peers, PROXY_PEER])

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket") and over_unix_socket(scope):
            scope = {**scope, "client": (PROXY_PEER, 0)}
        await self.app(scope, receive, send)


def unix_listener(path: Path) -> socket.socket:
    """A listening Unix socket at ``path`` (mode 0660); a stale socket of an earlier process
    life is replaced, anything else at that path is refused."""
    if path.exists() or path.is_symlink():
        if not stat.S_ISSOCK(path.lstat().st_mode):
            raise ValueError(f"--proxy-socket {path} exists and is not a socket")
        path.unlink()
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.bind(str(path))
        path.chmod(SOCKET_MODE)
        sock.listen(128)
    except OSError:
        sock.close()
        raise
    sock.set_inheritable(True)
    return sock
