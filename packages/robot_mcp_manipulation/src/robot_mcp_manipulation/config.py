"""Process settings from the environment, validated at start-up (fail fast, clear errors)."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import platformdirs
from pydantic import BaseModel, ConfigDict, Field, SecretStr, ValidationError, field_validator

DEFAULT_PORT = 9102
DEFAULT_EVENTS_URL = "http://127.0.0.1:8000/api/agent/events"
APP_NAME = "robot-mcp-manipulation"
_ROS_NAME = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")


def default_outbox_path() -> Path:
    """The outbox lives in the per-user data dir, never the working directory."""
    return platformdirs.user_data_path(APP_NAME) / "outbox.sqlite3"


class ConfigError(ValueError):
    """The environment does not describe a valid configuration."""


class ManipulationSettings(BaseModel):
    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)

    pick_action: str = Field(default="/manipulation/pick", alias="MANIP_PICK_ACTION")
    place_action: str = Field(default="/manipulation/place", alias="MANIP_PLACE_ACTION")
    held_topic: str = Field(default="/manipulation/held", alias="MANIP_HELD_TOPIC")
    server_timeout_s: float = Field(default=5.0, gt=0.0, le=120.0, alias="MANIP_SERVER_TIMEOUT_S")
    cancel_timeout_s: float = Field(default=5.0, gt=0.0, le=60.0, alias="MANIP_CANCEL_TIMEOUT_S")
    task_timeout_s: float = Field(default=60.0, gt=0.0, le=3600.0, alias="MANIP_TASK_TIMEOUT_S")
    max_age_s: float = Field(default=0.0, ge=0.0, le=3600.0, alias="MANIP_MAX_DETECTION_AGE_S")
    # issue 27: the brain's lease (required: no motion without a fresh one) and this server's
    # own dead-man lock (never two publishers on one lock topic: navigation has the plain one)
    supervision: Literal["required", "off"] = Field(default="required", alias="MANIP_SUPERVISION")
    lock_topic: str = Field(default="/robot/supervisor_lock/manipulation", alias="MANIP_LOCK_TOPIC")
    lock_hz: float = Field(default=20.0, ge=10.0, le=100.0, alias="MANIP_LOCK_HZ")
    lease_max_ttl_s: float = Field(default=2.0, gt=0.0, le=10.0, alias="MANIP_LEASE_MAX_TTL_S")
    events_url: str = Field(default=DEFAULT_EVENTS_URL, alias="RVC_EVENTS_URL")
    event_secret: SecretStr | None = Field(default=None, alias="RVC_EVENT_SECRET")
    outbox_path: Path = Field(default_factory=default_outbox_path, alias="MANIP_OUTBOX")
    transport: Literal["stdio", "sse", "streamable-http"] = Field(
        default="stdio", alias="MCP_TRANSPORT"
    )
    host: str = Field(default="127.0.0.1", alias="MCP_HOST")
    port: int = Field(default=DEFAULT_PORT, ge=1, le=65535, alias="MCP_PORT")
    log_level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = Field(
        default="INFO", alias="LOG_LEVEL"
    )

    @field_validator("event_secret", mode="before")
    @classmethod
    def _empty_secret_is_none(cls, value: object) -> object:
        return None if value in ("", None) else value

    @field_validator("pick_action", "place_action", "held_topic", "lock_topic")
    @classmethod
    def _ros_name(cls, value: str) -> str:
        if not _ROS_NAME.match(value):
            raise ValueError(
                "must be an absolute ROS name such as /manipulation/pick "
                "(letters, digits, underscores, separated by /)"
            )
        return value

    @field_validator("outbox_path")
    @classmethod
    def _absolute(cls, value: Path) -> Path:
        if not value.is_absolute():
            raise ValueError("must be an absolute path (the working directory is not state)")
        return value

    @field_validator("events_url")
    @classmethod
    def _http_url(cls, value: str) -> str:
        if not value.startswith(("http://", "https://")):
            raise ValueError("must be an http:// or https:// URL")
        return value

    @field_validator("supervision", mode="before")
    @classmethod
    def _lower(cls, value: object) -> object:
        return value.lower() if isinstance(value, str) else value

    @field_validator("log_level", mode="before")
    @classmethod
    def _upper(cls, value: object) -> object:
        return value.upper() if isinstance(value, str) else value


_ALIASES = {f.alias for f in ManipulationSettings.model_fields.values() if f.alias is not None}


def load_settings(environ: Mapping[str, str]) -> ManipulationSettings:
    """Settings from an environment mapping; a bad value raises ConfigError naming it."""
    values = {key: value for key, value in environ.items() if key in _ALIASES}
    try:
        return ManipulationSettings.model_validate(values)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in err['loc'])}: {err['msg']}" for err in exc.errors()
        )
        raise ConfigError(f"invalid manipulation settings: {problems}") from exc
