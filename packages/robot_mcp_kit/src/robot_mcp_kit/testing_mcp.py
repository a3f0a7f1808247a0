"""Reading a kit tool's answer in tests: every tool answers with ``structuredContent`` and a
text block that mirrors it (a tool error carries its ``{"error", "detail"}`` JSON as text)."""

from __future__ import annotations

import json
from typing import Any, cast

from mcp import Client
from mcp.types import RequestParamsMeta


async def tool_answer(
    client: Client,
    tool: str,
    args: dict[str, Any] | None = None,
    meta: dict[str, Any] | None = None,
) -> Any:
    """A tool's structuredContent object, or ``{"_error": payload}`` for a tool error.
    ``meta``: the request's ``_meta`` (e.g. ``caller.approval_meta(...)``).

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
