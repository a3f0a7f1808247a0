"""Reading a tool error's ``{"error", "detail"}`` back (the brain, a test): plain Python, no MCP
SDK, so a client's application layer can read tool errors without importing a server's side."""

from __future__ import annotations

import json
import re

SDK_PREFIX = re.compile(r"^Error executing tool [^:]*: ", re.DOTALL)


def parse_tool_error(text: str) -> dict[str, str] | None:
    """``{"error", "detail"}`` from an isError tool result text (with or without the SDK's
    ``Error executing tool ...:`` prefix), or None if the text is not such an error."""
    body = SDK_PREFIX.sub("", text.strip(), count=1)
    try:
        data = json.loads(body)
    except ValueError:
        return None
    if (
        isinstance(data, dict)
        and isinstance(data.get("error"), str)
        and isinstance(data.get("detail"), str)
    ):
        return {"error": data["error"], "detail": data["detail"]}
    return None
