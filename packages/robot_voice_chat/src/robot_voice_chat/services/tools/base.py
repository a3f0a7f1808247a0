"""The tool port: a flat list of dotted tools (``server.tool``) and one way to call them."""

from __future__ import annotations

import abc
from collections.abc import Awaitable, Callable
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel, Field, SecretStr, ValidationInfo, field_validator

from robot_voice_chat.services.llm.base import ToolDefinition

Transport = Literal["stdio", "sse", "streamable_http"]
ConnectionState = Literal["connected", "disconnected", "connecting"]
ServerListener = Callable[[str], Awaitable[None]]
ElicitationAnswer = tuple[Literal["accept", "decline", "cancel"], dict[str, Any] | None]
# (server, message, requested JSON schema) → the person's answer: an MCP server's question
ElicitationHandler = Callable[[str, str, dict[str, Any]], Awaitable[ElicitationAnswer]]
MIN_EVENT_SECRET_BYTES = 32
MIN_CREDENTIAL_BYTES = 32  # what the servers accept (robot_mcp_kit.service_auth)


@dataclass(frozen=True)
class ApprovedCall:
    """An operator approved this exact call: the MCP backend tells the server (``_meta``)."""

    tool: str  # server.tool
    arguments: dict[str, Any]
    approval_id: str
    by: str


# set by the guard around the one call an operator approved; read by the MCP backend
approved_call: ContextVar[ApprovedCall | None] = ContextVar("approved_call", default=None)


class McpServerConfig(BaseModel):
    """One entry of ``config/tools/mcp.yaml``."""

    name: str = Field(pattern=r"^[A-Za-z0-9_\-]+$")
    transport: Transport = "sse"
    url: str | None = None
    command: str | None = None
    args: list[str] = Field(default_factory=list)
    env: dict[str, str] = Field(default_factory=dict)
    event_secret: SecretStr | None = None
    auth_token: SecretStr | None = None
    """This server's credential (its ``MCP_AUTH_TOKEN``), sent as ``Authorization: Bearer``
    on every HTTP request; empty = none (stdio needs none)."""
    approval_secret: SecretStr | None = None
    """The secret this server checks approvals with (its ``MCP_APPROVAL_SECRET``): the brain
    signs the approval of every call an operator approved with it (``robot_mcp_kit.approvals``);
    empty = the brain sends none and a server that demands one refuses the call."""
    motion: bool = False
    safety_stop_tool: str | None = None
    read_tools: list[str] = Field(default_factory=list)
    """A motion server's tools that only read: with the task contract's ``get_task`` /
    ``list_tasks`` and its stop tools, the only ones that pass while the software stop is
    latched. The brain's own list: what the server's annotations claim never counts
    (issue 27 item 4)."""
    optional: bool = False
    """A server the stack may run without (e.g. ``episodic``): readiness does not wait for it;
    its tools are offered while it is connected."""

    @field_validator("auth_token", "approval_secret")
    @classmethod
    def _usable_credential(cls, token: SecretStr | None, info: ValidationInfo) -> SecretStr | None:
        """Empty = none; anything else must be >= 32 bytes (the servers refuse less)."""
        value = token.get_secret_value().strip() if token is not None else ""
        if not value:
            return None
        if len(value.encode()) < MIN_CREDENTIAL_BYTES:
            variable = (
                "MCP_AUTH_TOKEN" if info.field_name == "auth_token" else "MCP_APPROVAL_SECRET"
            )
            raise ValueError(
                f"{info.field_name} is {len(value.encode())} bytes; the server's {variable} "
                f"has at least {MIN_CREDENTIAL_BYTES}"
            )
        return SecretStr(value)

    @property
    def needs_credential(self) -> bool:
        return self.transport != "stdio"

    @field_validator("event_secret")
    @classmethod
    def _strong_secret(cls, secret: SecretStr | None) -> SecretStr | None:
        """Empty = this server cannot post events; anything else must be >= 32 bytes."""
        value = secret.get_secret_value() if secret is not None else ""
        if value and len(value.encode()) < MIN_EVENT_SECRET_BYTES:
            raise ValueError(
                f"event_secret is {len(value.encode())} bytes; at least "
                f"{MIN_EVENT_SECRET_BYTES} are required (python3 -c "
                '"import secrets; print(secrets.token_hex(32))")'
            )
        return secret

    @property
    def can_post_events(self) -> bool:
        return self.event_secret is not None and bool(self.event_secret.get_secret_value())


class ToolOutcome(BaseModel):
    """What a tool returned. Failures are values the LLM can read (``is_error``)."""

    text: str
    is_error: bool = False


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
