"""MCP clients with a server's credential, as the brain and an operator's tool connect.

Every MCP server over sse / streamable-http demands ``Authorization: Bearer <token>`` on each
request (``robot_mcp_kit.service_auth``); tests start servers with :func:`fresh_token` in
``MCP_AUTH_TOKEN`` and reach them through :func:`mcp_transport`.

:func:`approval_meta` signs an operator's approval as the brain does, written from the recipe
in ``robot_mcp_kit``'s README ("Approvals"), not from the kit's code: a test seeding a stack's
memory (``mission_driver.seed_memory``) uses it, and the kit's tests check it against the
servers' verifier.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import secrets
import time
from collections.abc import AsyncIterator, Mapping
from contextlib import asynccontextmanager
from typing import Any

import httpx
from mcp.client.sse import sse_client
from mcp.client.streamable_http import streamable_http_client
from mcp.shared._httpx_utils import create_mcp_http_client  # the SDK's own client defaults


def fresh_token() -> str:
    """A credential as install.sh makes one (32 random bytes, URL-safe)."""
    return secrets.token_urlsafe(32)


def approval_meta(
    secret: str,
    *,
    server: str,
    tool: str,
    arguments: Mapping[str, Any],
    approval_id: str,
    by: str,
    expires: int | None = None,
) -> dict[str, Any]:
    """The ``_meta`` of a tool call that ``by`` approved, signed with the server's approval
    secret (its ``MCP_APPROVAL_SECRET``); ``expires`` defaults to 60 s from now."""
    canonical = json.dumps(dict(arguments), sort_keys=True, separators=(",", ":"))
    call = hashlib.sha256(f"{tool}\n{canonical}".encode()).hexdigest()
    until = int(time.time()) + 60 if expires is None else expires
    key = hmac.new(secret.encode(), b"robot-stack approval key v1", hashlib.sha256).digest()
    fields = ["robot-stack/approval/v1", server, tool, call, approval_id, by, until]
    message = json.dumps(fields, separators=(",", ":")).encode("ascii")
    entry = {
        "v": 1,
        "server": server,
        "tool": tool,
        "call": call,
        "approval_id": approval_id,
        "by": by,
        "expires": until,
        "sig": hmac.new(key, message, hashlib.sha256).hexdigest(),
    }
    return {"robot-stack/approval": entry}


def bearer(token: str | None) -> dict[str, str]:
    """The header that presents ``token`` (none for None)."""
    return {"Authorization": f"Bearer {token}"} if token is not None else {}


@asynccontextmanager
async def mcp_transport(url: str, token: str | None) -> AsyncIterator[Any]:
    """An MCP client transport for ``url`` (``…/sse`` = SSE, else streamable-http) that sends
    ``token`` on every request: ``async with Client(mcp_transport(url, token)) as client``."""
    headers = bearer(token) or None
    if url.rstrip("/").endswith("/sse"):
        async with sse_client(url, headers=headers) as streams:
            yield streams
        return
    async with (
        create_mcp_http_client(headers=headers) as http,
        streamable_http_client(url, http_client=http) as streams,
    ):
        yield streams


def assert_refuses_strangers(url: str, realm: str) -> None:
    """A running MCP server at ``url`` (``…/sse`` or ``…/mcp``) answers a request without a
    credential and one with a wrong credential with 401 and ``WWW-Authenticate: Bearer
    realm="<realm>"`` — for the GET stream and for a POSTed message alike."""
    message = {"jsonrpc": "2.0", "id": 1, "method": "tools/list"}
    post_url = url.replace("/sse", "/messages/?session_id=00000000000000000000000000000000")
    accept = {"accept": "application/json, text/event-stream"}
    with httpx.Client(timeout=5.0) as http:
        for token in (None, fresh_token()):
            for answer in (
                http.get(url, headers={**bearer(token), **accept}),
                http.post(post_url, headers={**bearer(token), **accept}, json=message),
            ):
                where = f"{answer.request.method} {url} ({'wrong' if token else 'no'} credential)"
                assert answer.status_code == 401, f"{where}: {answer.status_code} {answer.text}"
                challenge = answer.headers.get("www-authenticate", "")
                assert challenge.startswith(f'Bearer realm="{realm}"'), f"{where}: {challenge}"
