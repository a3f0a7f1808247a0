"""The settings every motion server reads the same way (navigation, manipulation): where its
task events go, how it serves MCP, its log level, and the other goal clients of its actions
allowed on the graph while the stop holds (issue 35). A server subclasses
:class:`MotionServerSettings` with its own fields, its ``port`` and its ``goal_clients``
variable."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, SecretStr

from robot_mcp_kit.settings_fields import EventsUrl, LogLevel, empty_is_none

DEFAULT_EVENTS_URL = "http://127.0.0.1:8000/api/agent/events"


class MotionServerSettings(BaseModel):
    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)

    events_url: EventsUrl = Field(default=DEFAULT_EVENTS_URL, alias="RVC_EVENTS_URL")
    event_secret: Annotated[SecretStr | None, BeforeValidator(empty_is_none)] = Field(
        default=None, alias="RVC_EVENT_SECRET"
    )
    transport: Literal["stdio", "sse", "streamable-http"] = Field(
        default="stdio", alias="MCP_TRANSPORT"
    )
    host: str = Field(default="127.0.0.1", alias="MCP_HOST")
    log_level: LogLevel = Field(default="INFO", alias="LOG_LEVEL")
    goal_clients: str = Field(default="", max_length=1000)  # node names, comma-separated

    @property
    def allowed_goal_clients(self) -> tuple[str, ...]:
        return tuple(name.strip() for name in self.goal_clients.split(",") if name.strip())
