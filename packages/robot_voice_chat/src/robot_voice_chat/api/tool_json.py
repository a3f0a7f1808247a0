"""Read-only capability calls for the UI: a tool's JSON answer, or a 503 JSON that says why."""

from __future__ import annotations

import json
from typing import Any

from fastapi.responses import JSONResponse

from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.services.tools.base import ToolBackend

# The UI polls in the background: a tool the policy wants confirmed is refused here, never
# turned into an approval card nobody asked for (an operator approves what the robot does).
BACKGROUND_READ = DispatchContext(may_ask=False, caller="the UI's background read")


class ToolUnavailableError(RuntimeError):
    def __init__(self, tool: str, detail: str) -> None:
        super().__init__(detail)
        self.tool = tool
        self.detail = detail

    def response(self) -> JSONResponse:
        return unavailable(self.tool.partition(".")[0] + "_unavailable", self.detail)


def unavailable(error: str, detail: str) -> JSONResponse:
    return JSONResponse({"error": error, "detail": detail}, status_code=503)


async def call_json(
    tools: ToolBackend, name: str, arguments: dict[str, object], timeout_s: float
) -> dict[str, Any]:
    """Call ``server.tool`` and decode its JSON object; ToolUnavailableError otherwise."""
    with dispatching(BACKGROUND_READ):
        outcome = await tools.call_tool(name, arguments, timeout_s=timeout_s)
    if outcome.is_error:
        raise ToolUnavailableError(name, outcome.text[:300])
    try:
        data = json.loads(outcome.text)
    except ValueError as exc:
        raise ToolUnavailableError(name, f"{name} answered no JSON: {outcome.text[:120]}") from exc
    if not isinstance(data, dict):
        raise ToolUnavailableError(name, f"{name} answered {type(data).__name__}, not an object")
    return data
