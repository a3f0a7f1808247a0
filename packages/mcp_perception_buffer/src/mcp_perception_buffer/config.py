"""Start-up configuration of the perception buffer, validated by Pydantic before anything starts."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import platformdirs
from pydantic import BaseModel, ConfigDict, Field, SecretStr, model_validator

DEFAULT_PORT = 9202
SERVER_NAME = "perception"
APP_NAME = "mcp-perception-buffer"

_ENV = {
    "vision_node_name": "VISION_NODE_NAME",
    "events_url": "RVC_EVENTS_URL",
    "event_secret": "RVC_EVENT_SECRET",
    "outbox_path": "PERCEPTION_OUTBOX_PATH",
    "max_count": "PERCEPTION_BUFFER_MAX_COUNT",
    "max_age_s": "PERCEPTION_BUFFER_MAX_AGE_S",
    "stale_after_s": "PERCEPTION_STALE_AFTER_S",
    "graph_poll_s": "PERCEPTION_GRAPH_POLL_S",
    "watch_poll_s": "PERCEPTION_WATCH_POLL_S",
    "call_timeout_s": "PERCEPTION_CALL_TIMEOUT_S",
    "ros_node_name": "PERCEPTION_ROS_NODE_NAME",
    "log_level": "LOG_LEVEL",
}


class PerceptionConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    vision_node_name: str = Field(default="vision_node", min_length=1)
    events_url: str | None = None
    """The brain's ``/api/agent/events``; unset = watch events are logged, not posted."""
    event_secret: SecretStr | None = None
    outbox_path: Path = Field(
        default_factory=lambda: platformdirs.user_data_path(APP_NAME) / "outbox.sqlite3"
    )
    """Per-user data dir by default (never the working directory: hosts spawn us from /)."""
    max_count: int = Field(default=50, ge=1, le=10_000)
    max_age_s: float = Field(default=300.0, gt=0)
    stale_after_s: float = Field(default=10.0, gt=0)
    graph_poll_s: float = Field(default=0.5, gt=0, le=30)
    watch_poll_s: float = Field(default=1.0, gt=0, le=60)
    gone_grace_s: float = Field(default=2.0, ge=0)
    call_timeout_s: float = Field(default=5.0, gt=0, le=120)
    wait_for_service_s: float = Field(default=3.0, ge=0, le=60)
    max_wait_s: float = Field(default=25.0, gt=0, le=120)
    """Upper bound of wait_for_result (MCP clients time a call out at ~30 s)."""
    ros_node_name: str = "mcp_perception_buffer"
    log_level: str = "INFO"

    @model_validator(mode="after")
    def _secret_with_url(self) -> PerceptionConfig:
        if self.events_url and (
            self.event_secret is None or not self.event_secret.get_secret_value()
        ):
            raise ValueError("RVC_EVENTS_URL is set but RVC_EVENT_SECRET is empty")
        return self

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> PerceptionConfig:
        env = os.environ if env is None else env
        return cls.model_validate({key: env[var] for key, var in _ENV.items() if env.get(var)})
