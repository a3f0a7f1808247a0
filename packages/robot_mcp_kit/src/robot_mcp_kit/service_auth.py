"""The service plane's credential check: a per-server bearer token on every HTTP request.

Why a bearer token, and not unix sockets or a full OAuth flow (issue 27): the MCP specification
leaves authorization optional; HTTP transports that do it send the credential as
``Authorization: Bearer <token>`` on *every* request, and a server answers a missing or
invalid one with 401 and ``WWW-Authenticate`` (RFC 6750) — exactly what this module does. On
one robot the clients are known in advance (the brain; an operator's tool such as the MCP
Inspector), so the token is provisioned once by ``deploy/install.sh`` into the server's and the
brain's env files instead of being issued by an authorization server, which would be one more
service to run and guard on the robot. Each server has its own token (its "audience"): the
memory server's token opens nothing else. Unix sockets would tie access to the brain's unix
user (an operator's tool would have to share it) and the Inspector and outside checks speak
HTTP URLs. stdio needs no credential: the parent process is the client (the specification's
"retrieve credentials from the environment").

Environment (read by :func:`service_auth`, for sse and streamable-http only):

- ``MCP_AUTH_TOKEN``: the brain's credential for this server (≥ 32 bytes). Required.
- ``MCP_OPERATOR_TOKEN``: optional second credential for an operator's tool (another value).
- ``MCP_AUTH=off``: a throwaway dev server without credentials (logged ``mcp_auth_disabled``
  at start; refused together with a token). Nothing in ``deploy/`` sets it.

A transport session belongs to the principal that opened it: a request for it with another
credential is answered as if it did not exist (404).

The tokens are ``SecretStr`` and never logged; a refusal logs ``mcp_auth_rejected`` with why
(``missing`` / ``invalid``), method, path and client address — never what was presented.
"""

from __future__ import annotations

import hmac
import json
from collections.abc import Awaitable, Callable, Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any

import structlog
from mcp.server.auth.middleware.bearer_auth import AuthenticatedUser
from mcp.server.auth.provider import AccessToken
from pydantic import SecretStr

from robot_mcp_kit.caller import BRAIN, OPERATOR, PRINCIPAL_SCOPE_KEY

# names of variables and a shell hint, not secrets
ENV_TOKEN = "MCP_AUTH_TOKEN"  # noqa: S105
ENV_OPERATOR_TOKEN = "MCP_OPERATOR_TOKEN"  # noqa: S105
ENV_MODE = "MCP_AUTH"
MIN_TOKEN_BYTES = 32
NEW_TOKEN_HINT = "python3 -c 'import secrets; print(secrets.token_urlsafe(32))'"  # noqa: S105

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

logger = structlog.get_logger("robot_mcp_kit.service_auth")


class ServiceAuthError(ValueError):
    """The credential settings cannot be used (missing, too short, contradictory)."""


@dataclass(frozen=True)
class ServiceAuth:
    """Who may call this server: (principal, token) pairs; none = open (``MCP_AUTH=off``)."""

    credentials: tuple[tuple[str, SecretStr], ...] = ()

    @property
    def enabled(self) -> bool:
        return bool(self.credentials)

    def identify(self, presented: str) -> str | None:
        """The principal whose token ``presented`` is, compared in constant time against
        every credential (no early exit), or None."""
        given = presented.encode()
        found: str | None = None
        for principal, token in self.credentials:
            if hmac.compare_digest(given, token.get_secret_value().encode()):
                found = principal
        return found


def service_auth(env: Mapping[str, str], transport: str) -> ServiceAuth:
    """The credentials of a server on ``transport`` from its environment (see module doc).
    stdio needs none; an HTTP transport without ``MCP_AUTH_TOKEN`` is refused unless
    ``MCP_AUTH=off`` says so explicitly."""
    if transport == "stdio":
        return ServiceAuth()
    mode = env.get(ENV_MODE, "required").strip().lower() or "required"
    if mode not in ("required", "off"):
        raise ServiceAuthError(f"{ENV_MODE} must be 'required' or 'off', got {mode!r}")
    brain = env.get(ENV_TOKEN, "").strip()
    operator = env.get(ENV_OPERATOR_TOKEN, "").strip()
    if mode == "off":
        if brain or operator:
            raise ServiceAuthError(
                f"{ENV_MODE}=off but a token is set ({ENV_TOKEN} / {ENV_OPERATOR_TOKEN}): "
                f"remove one of them"
            )
        return ServiceAuth()
    if not brain:
        raise ServiceAuthError(
            f"{ENV_TOKEN} is not set: {transport} clients must present this server's "
            f"credential (make one with {NEW_TOKEN_HINT} and give the brain the same value), "
            f"or set {ENV_MODE}=off for a throwaway dev server"
        )
    credentials = [(BRAIN, _strong(ENV_TOKEN, brain))]
    if operator:
        if hmac.compare_digest(operator.encode(), brain.encode()):
            raise ServiceAuthError(f"{ENV_OPERATOR_TOKEN} must differ from {ENV_TOKEN}")
        credentials.append((OPERATOR, _strong(ENV_OPERATOR_TOKEN, operator)))
    return ServiceAuth(tuple(credentials))


def _strong(name: str, value: str) -> SecretStr:
    size = len(value.encode())
    if size < MIN_TOKEN_BYTES:
        raise ServiceAuthError(
            f"{name} is {size} bytes; at least {MIN_TOKEN_BYTES} are required ({NEW_TOKEN_HINT})"
        )
    return SecretStr(value)


def bearer_token(header: str | None) -> str | None:
    """The token of an ``Authorization: Bearer <token>`` value (scheme case-insensitive)."""
    if header is None:
        return None
    scheme, _, token = header.strip().partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        return None
    return token.strip()


class BearerAuthMiddleware:
    """ASGI middleware in front of a whole MCP app: every HTTP request (the SSE GET stream,
    every POSTed message, streamable-http's POST/GET/DELETE) must carry a credential of
    ``auth``; else 401 with ``WWW-Authenticate: Bearer realm="<server>"`` (plus
    ``error="invalid_token"`` for a wrong one). The caller's principal rides on in the ASGI
    scope (``PRINCIPAL_SCOPE_KEY``) for :mod:`robot_mcp_kit.caller`, and as the scope's
    ``user``: the SDK's transports remember which principal opened a session (the SSE stream,
    streamable-http's initialize) and answer a message, GET or DELETE for that session sent
    with another credential 404 "session not found", exactly as for a session that does not
    exist (issue 35 item 5)."""

    def __init__(self, app: ASGIApp, auth: ServiceAuth, server: str) -> None:
        if not auth.enabled:
            raise ValueError("BearerAuthMiddleware needs at least one credential")
        self.app = app
        self.auth = auth
        self.server = server

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)  # lifespan
            return
        token = bearer_token(_header(scope, b"authorization"))
        principal = self.auth.identify(token) if token is not None else None
        if principal is not None:
            await self.app(
                {**scope, PRINCIPAL_SCOPE_KEY: principal, "user": _session_owner(principal)},
                receive,
                send,
            )
            return
        reason = "missing" if token is None else "invalid"
        client = scope.get("client")
        logger.warning(
            "mcp_auth_rejected",
            server=self.server,
            reason=reason,
            method=scope.get("method", "WEBSOCKET"),
            path=scope.get("path", ""),
            client=f"{client[0]}:{client[1]}" if client else None,
        )
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        await self._unauthorized(send, reason)

    async def _unauthorized(self, send: Send, reason: str) -> None:
        challenge = f'Bearer realm="{self.server}"'
        if reason == "invalid":
            challenge += ', error="invalid_token"'
            body = {
                "error": "invalid_token",
                "error_description": f"this credential is not valid for the {self.server} "
                "MCP server",
            }
        else:
            body = {
                "error": "unauthorized",
                "error_description": f"the {self.server} MCP server needs its credential: "
                "Authorization: Bearer <token>",
            }
        payload = json.dumps(body).encode()
        await send(
            {
                "type": "http.response.start",
                "status": 401,
                "headers": [
                    (b"content-type", b"application/json"),
                    (b"content-length", str(len(payload)).encode()),
                    (b"www-authenticate", challenge.encode()),
                ],
            }
        )
        await send({"type": "http.response.body", "body": payload})


def _session_owner(principal: str) -> AuthenticatedUser:
    """The SDK's notion of who owns a transport session: the principal, never the token."""
    return AuthenticatedUser(AccessToken(token=principal, client_id=principal, scopes=[]))


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", []):
        if key.lower() == name:
            return bytes(value).decode("latin-1")
    return None
