"""The one choke point in front of every MCP dispatch of the brain.

Every caller (the mission dispatcher for any planner, prepared reactions, the fast path, the
memory client, the UI's routes, the stop itself) holds this backend, never the raw one, so a
call that the latch or the policy refuses is never sent. Refusals are tool errors the planner
can read and replan on: ``{"error": CODE, "detail": sentence}``.
"""

from __future__ import annotations

import json

import structlog

from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED, SafetyLatch, latched_sentence
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.tools.base import (
    ConnectionState,
    McpServerConfig,
    ServerListener,
    ToolBackend,
    ToolOutcome,
)

logger = structlog.get_logger(__name__)
# tools of a motion server that stop or observe: never refused by the latch
TASK_READ_TOOLS = frozenset({"get_task", "list_tasks"})
STOP_TOOLS = frozenset({"cancel_task"})


def refusal(code: str, detail: str, **extra: object) -> ToolOutcome:
    return ToolOutcome(text=json.dumps({"error": code, "detail": detail, **extra}), is_error=True)


class GuardedToolBackend(ToolBackend):
    def __init__(self, inner: ToolBackend, latch: SafetyLatch) -> None:
        self.inner = inner
        self.latch = latch

    def is_stop_tool(self, name: str) -> bool:
        server, _, tool = name.partition(".")
        cfg = self.inner.servers().get(server)
        return tool in STOP_TOOLS or (cfg is not None and tool == cfg.safety_stop_tool)

    def moves(self, name: str) -> bool:
        """A call that can make the robot move: any tool of a motion server except those
        that stop it or read from it."""
        server, _, tool = name.partition(".")
        cfg = self.inner.servers().get(server)
        if cfg is None or not cfg.motion or self.is_stop_tool(name) or tool in TASK_READ_TOOLS:
            return False
        definition = self.definition(name)
        hints = definition.annotations if definition is not None else None
        return not (hints or {}).get("readOnlyHint", False)

    def definition(self, name: str) -> ToolDefinition | None:
        return next((t for t in self.inner.list_tools() if t.name == name), None)

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        if self.latch.latched and self.moves(name):
            logger.warning("tool_refused", tool=name, code=SAFETY_STOP_LATCHED)
            return refusal(
                SAFETY_STOP_LATCHED, f"{name} was not sent. " + latched_sentence(self.latch.state)
            )
        return await self.inner.call_tool(name, arguments, timeout_s)

    # --- the rest of the port, unchanged -------------------------------------------------
    def list_tools(self) -> list[ToolDefinition]:
        return self.inner.list_tools()

    def servers(self) -> dict[str, McpServerConfig]:
        return self.inner.servers()

    def server_states(self) -> dict[str, ConnectionState]:
        return self.inner.server_states()

    def add_connect_listener(self, listener: ServerListener) -> None:
        self.inner.add_connect_listener(listener)

    def has_tool(self, name: str) -> bool:
        return self.inner.has_tool(name)

    async def start(self) -> None:
        await self.inner.start()

    async def aclose(self) -> None:
        await self.inner.aclose()
