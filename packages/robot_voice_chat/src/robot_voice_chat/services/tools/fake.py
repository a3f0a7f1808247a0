"""A fake tool backend: handlers per dotted tool name; records every call."""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from typing import Any

from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.tools.base import (
    ConnectionState,
    ServerListener,
    ToolBackend,
    ToolOutcome,
)
from robot_voice_chat.settings import McpServerConfig

Handler = Callable[[dict[str, Any]], Awaitable[Any] | Any]


class FakeToolBackend(ToolBackend):
    def __init__(self, servers: list[McpServerConfig] | None = None) -> None:
        self._servers = {s.name: s for s in servers or []}
        self._handlers: dict[str, Handler] = {}
        self._definitions: dict[str, ToolDefinition] = {}
        self.calls: list[tuple[str, dict[str, Any]]] = []
        self.listeners: list[ServerListener] = []
        self.lost_listeners: list[ServerListener] = []
        self.states: dict[str, ConnectionState] = dict.fromkeys(self._servers, "connected")

    def add(
        self,
        name: str,
        handler: Handler,
        description: str = "",
        **props: Any,
    ) -> None:
        self._handlers[name] = handler
        schema = {"type": "object", "properties": {k: {"type": v} for k, v in props.items()}}
        previous = self._definitions.get(name)
        self._definitions[name] = ToolDefinition(
            name=name,
            description=description or name,
            parameters=schema,
            annotations=previous.annotations if previous else None,
        )
        server = name.split(".", 1)[0]
        if server not in self._servers:
            self._servers[server] = McpServerConfig(name=server, url="http://127.0.0.1:1/sse")
            self.states[server] = "connected"

    def annotate(self, name: str, annotations: dict[str, Any]) -> None:
        """Publish MCP tool annotations for ``name`` as its server would."""
        self._definitions[name] = self._definitions[name].model_copy(
            update={"annotations": annotations}
        )

    def list_tools(self) -> list[ToolDefinition]:
        """Like the MCP backend: a server that is not connected lists no tools."""
        return [
            d
            for name, d in self._definitions.items()
            if self.states.get(name.split(".", 1)[0], "connected") == "connected"
        ]

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        self.calls.append((name, dict(arguments)))
        server = name.split(".", 1)[0]
        if self.states.get(server, "connected") != "connected":
            return ToolOutcome(text=f"error: server {server!r} is not connected", is_error=True)
        handler = self._handlers.get(name)
        if handler is None:
            return ToolOutcome(text=f"unknown tool {name}", is_error=True)
        try:
            result = handler(dict(arguments))
            if isinstance(result, Awaitable):
                result = await result
        except ValueError as exc:
            return ToolOutcome(text=str(exc), is_error=True)
        if isinstance(result, ToolOutcome):
            return result
        return ToolOutcome(text=result if isinstance(result, str) else json.dumps(result))

    def called(self, name: str) -> list[dict[str, Any]]:
        return [args for tool, args in self.calls if tool == name]

    def servers(self) -> dict[str, McpServerConfig]:
        return dict(self._servers)

    def server_states(self) -> dict[str, ConnectionState]:
        return dict(self.states)

    def add_connect_listener(self, listener: ServerListener) -> None:
        self.listeners.append(listener)

    async def reconnected(self, server: str) -> None:
        self.states[server] = "connected"
        for listener in self.listeners:
            await listener(server)

    def add_disconnect_listener(self, listener: ServerListener) -> None:
        self.lost_listeners.append(listener)

    async def disconnected(self, server: str) -> None:
        self.states[server] = "disconnected"
        for listener in self.lost_listeners:
            await listener(server)
