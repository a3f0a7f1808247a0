"""Reading a kit tool's answer in tests: every tool answers with ``structuredContent`` and a
text block that mirrors it (a tool error carries its ``{"error", "detail"}`` JSON as text);
:func:`approved` makes the ``_meta`` of a call an operator approved, as the brain signs it."""

from __future__ import annotations

import json
import uuid
from typing import Any, cast

from mcp import Client
from mcp.types import RequestParamsMeta

from robot_mcp_kit.approvals import signed_approval


def approved(
    secret: str, server: str, tool: str, arguments: dict[str, Any], by: str = "test operator"
) -> dict[str, Any]:
    """The ``_meta`` of exactly this call approved by ``by``, signed with ``server``'s approval
    secret, under a fresh approval id (each one works once)."""
    return signed_approval(
        secret,
        server=server,
        tool=tool,
        arguments=arguments,
        approval_id=f"ap-{uuid.uuid4().hex[:12]}",
        by=by,
    )


async def tool_answer(
    client: Client,
    tool: str,
    args: dict[str, Any] | None = None,
    meta: dict[str, Any] | None = None,
) -> Any:
    """A tool's structuredContent object, or ``{"_error": payload}`` for a tool error.
    ``meta``: the request's ``_meta`` (e.g. :func:`approved`).

    Fails the test when a successful answer lacks structuredContent or its text block does not
    mirror it (what an MCP client that reads only text would see)."""
    result = await client.call_tool(
        tool, args or {}, meta=cast(RequestParamsMeta, meta) if meta is not None else None
    )
    payload = json.loads(result.content[0].text)  # type: ignore[union-attr]
    if result.is_error:
        return {"_error": payload}
    assert isinstance(result.structured_content, dict)
    assert payload == result.structured_content
    return result.structured_content
