"""MCP clients with a server's credential, as the brain and an operator's tool connect.

Every MCP server over sse / streamable-http demands ``Authorization: Bearer <token>`` on each
request (``robot_mcp_kit.service_auth``); tests start servers with :func:`fresh_token` in
``MCP_AUTH_TOKEN`` and reach them through :func:`mcp_transport`.
"""

from __future__ import annotations

import secrets
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from mcp.client.sse import sse_client
from mcp.client.streamable_http import streamable_http_client
from mcp.shared._httpx_utils import create_mcp_http_client  # the SDK's own client defaults


def fresh_token() -> str:
    """A credential as install.sh makes one (32 random bytes, URL-safe)."""
    return secrets.token_urlsafe(32)


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
