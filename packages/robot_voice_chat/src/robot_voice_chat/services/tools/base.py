"""The tool port: a flat list of dotted tools (``server.tool``) and one way to call them."""

from __future__ import annotations

import abc
from collections.abc import Awaitable, Callable
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel

from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.settings import McpServerConfig

ConnectionState = Literal["connected", "disconnected", "connecting"]
ServerListener = Callable[[str], Awaitable[None]]
ElicitationAnswer = tuple[Literal["accept", "decline", "cancel"], dict[str, Any] | None]
# (server, message, requested JSON schema) → the person's answer: an MCP server's question
ElicitationHandler = Callable[[str, str, dict[str, Any]], Awaitable[ElicitationAnswer]]


@dataclass(frozen=True)
class ApprovedCall:
    """An operator approved this exact call: the MCP backend tells the server (``_meta``)."""

    tool: str  # server.tool
    arguments: dict[str, Any]
    approval_id: str
    by: str


# set by the guard around the one call an operator approved; read by the MCP backend
approved_call: ContextVar[ApprovedCall | None] = ContextVar("approved_call", default=None)


class ToolOutcome(BaseModel):
    """What a tool returned. Failures are values the LLM can read (``is_error``)."""

    text: str
    is_error: bool = False
    # the call went out and its server went away (or went silent) before it answered: what it
    # started, if anything, is unknown
    cut_off: bool = False


class ToolBackend(abc.ABC):
    """Port for the capability tools (MCP servers behind it)."""

    @abc.abstractmethod
    def list_tools(self) -> list[ToolDefinition]:
        """Tools of every connected server, dotted names, unchanged schemas."""

    @abc.abstractmethod
    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        """Call ``server.tool``; never raises for tool/transport failures."""

    @abc.abstractmethod
    def servers(self) -> dict[str, McpServerConfig]: ...

    @abc.abstractmethod
    def server_states(self) -> dict[str, ConnectionState]: ...

    @abc.abstractmethod
    def add_connect_listener(self, listener: ServerListener) -> None:
        """``listener(server)`` runs whenever a server (re)connects (§5.4 reconciliation)."""

    @abc.abstractmethod
    def add_disconnect_listener(self, listener: ServerListener) -> None:
        """``listener(server)`` runs when a connected server is lost (its health check or a
        call failed): live tasks there cannot report until it is back."""

    def has_tool(self, name: str) -> bool:
        return any(tool.name == name for tool in self.list_tools())

    def set_elicitation_handler(self, handler: ElicitationHandler) -> None:  # noqa: B027
        """Declare MCP elicitation to the servers and route their questions to ``handler``;
        adapters without servers keep the default (nothing to ask)."""

    def check_now(self, server: str) -> None:  # noqa: B027 - optional hook
        """Health-check ``server`` now, or connect to it now if it is down (instead of at the
        next interval); adapters without connections keep the default."""

    async def start(self) -> None:  # noqa: B027 - optional hook
        """Begin connecting; adapters without connections keep the default."""

    async def aclose(self) -> None:  # noqa: B027 - optional hook
        """Disconnect."""
