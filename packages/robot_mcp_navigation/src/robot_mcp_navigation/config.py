"""Process settings from the environment, validated at start-up (fail fast, clear errors)."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import platformdirs
from pydantic import BaseModel, ConfigDict, Field, SecretStr, ValidationError, field_validator

DEFAULT_PORT = 9101
DEFAULT_EVENTS_URL = "http://127.0.0.1:8000/api/agent/events"
APP_NAME = "robot-mcp-navigation"
_ROS_NAME = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")


def default_outbox_path() -> Path:
    """The outbox lives in the per-user data dir, never the working directory (a server an
    MCP host spawns from ``/`` must still find and keep its undelivered events)."""
    return platformdirs.user_data_path(APP_NAME) / "outbox.sqlite3"


def default_pose_path() -> Path:
    """The simulated base's last pose (kept across restarts), beside the outbox."""
    return platformdirs.user_data_path(APP_NAME) / "pose.json"


def default_map_path() -> Path:
    """The office map shipped with the package (``config/maps/office.yaml``)."""
    return Path(__file__).resolve().parents[2] / "config" / "maps" / "office.yaml"


class ConfigError(ValueError):
    """The environment does not describe a valid configuration."""


class NavigationSettings(BaseModel):
    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)

    map_path: Path = Field(default_factory=default_map_path, alias="NAV_MAP")
    motion: Literal["simulated", "nav2"] = Field(default="simulated", alias="NAV_MOTION")
    nav2_action: str = Field(default="/navigate_to_pose", alias="NAV2_ACTION")
    pose_topic: str = Field(default="/amcl_pose", alias="NAV_POSE_TOPIC")
    map_topic: str = Field(default="/map", alias="NAV_MAP_TOPIC")
    costmap_topic: str = Field(default="/global_costmap/costmap", alias="NAV_COSTMAP_TOPIC")
    plan_topic: str = Field(default="/plan", alias="NAV_PLAN_TOPIC")
    nav2_server_timeout_s: float = Field(
        default=5.0, gt=0.0, le=120.0, alias="NAV2_SERVER_TIMEOUT_S"
    )
    nav2_cancel_timeout_s: float = Field(
        default=5.0, gt=0.0, le=60.0, alias="NAV2_CANCEL_TIMEOUT_S"
    )
    time_scale: float = Field(default=1.0, gt=0.0, le=1000.0, alias="NAV_TIME_SCALE")
    failures_enabled: bool = Field(default=True, alias="NAV_FAILURES")
    progress_interval_s: float = Field(default=2.0, gt=0.0, alias="NAV_PROGRESS_INTERVAL_S")
    progress_pct_step: float = Field(default=10.0, gt=0.0, le=100.0, alias="NAV_PROGRESS_PCT_STEP")
    tick_s: float = Field(default=0.05, gt=0.0, le=1.0, alias="NAV_TICK_S")
    events_url: str = Field(default=DEFAULT_EVENTS_URL, alias="RVC_EVENTS_URL")
    event_secret: SecretStr | None = Field(default=None, alias="RVC_EVENT_SECRET")
    outbox_path: Path = Field(default_factory=default_outbox_path, alias="NAV_OUTBOX")
    pose_path: Path = Field(default_factory=default_pose_path, alias="NAV_POSE_PATH")
    transport: Literal["stdio", "sse", "streamable-http"] = Field(
        default="stdio", alias="MCP_TRANSPORT"
    )
    host: str = Field(default="127.0.0.1", alias="MCP_HOST")
    port: int = Field(default=DEFAULT_PORT, ge=1, le=65535, alias="MCP_PORT")
    log_level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = Field(
        default="INFO", alias="LOG_LEVEL"
    )
    # elicit: ask the MCP client's person to confirm each navigate_to (third-party hosts)
    confirm_motion: Literal["off", "elicit"] = Field(default="off", alias="NAV_CONFIRM_MOTION")
    # issue 27: the brain's lease (required: no motion without a fresh one) and the dead-man
    # lock on the robot's twist_mux (published with NAV_MOTION=nav2 and required supervision)
    supervision: Literal["required", "off"] = Field(default="required", alias="NAV_SUPERVISION")
    lock_topic: str = Field(default="/robot/supervisor_lock", alias="NAV_LOCK_TOPIC")
    lock_hz: float = Field(default=20.0, ge=10.0, le=100.0, alias="NAV_LOCK_HZ")
    lease_max_ttl_s: float = Field(default=2.0, gt=0.0, le=10.0, alias="NAV_LEASE_MAX_TTL_S")
    nav2_feedback_timeout_s: float = Field(
        default=3.0, ge=0.0, le=60.0, alias="NAV2_FEEDBACK_TIMEOUT_S"
    )
    pose_max_age_s: float = Field(default=0.0, ge=0.0, le=3600.0, alias="NAV_POSE_MAX_AGE_S")

    @field_validator("event_secret", mode="before")
    @classmethod
    def _empty_secret_is_none(cls, value: object) -> object:
        return None if value in ("", None) else value

    @field_validator("motion", "supervision", mode="before")
    @classmethod
    def _lower(cls, value: object) -> object:
        return value.strip().lower() if isinstance(value, str) else value

    @field_validator(
        "nav2_action", "pose_topic", "map_topic", "costmap_topic", "plan_topic", "lock_topic"
    )
    @classmethod
    def _ros_name(cls, value: str) -> str:
        if not _ROS_NAME.match(value):
            raise ValueError(
                "must be an absolute ROS name such as /navigate_to_pose "
                "(letters, digits, underscores, separated by /)"
            )
        return value

    @field_validator("outbox_path", "pose_path")
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

    @field_validator("log_level", mode="before")
    @classmethod
    def _upper(cls, value: object) -> object:
        return value.upper() if isinstance(value, str) else value


_ALIASES = {
    field.alias for field in NavigationSettings.model_fields.values() if field.alias is not None
}


def load_settings(environ: Mapping[str, str]) -> NavigationSettings:
    """Settings from an environment mapping; a bad value raises ConfigError naming it."""
    values = {key: value for key, value in environ.items() if key in _ALIASES}
    try:
        return NavigationSettings.model_validate(values)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in err['loc'])}: {err['msg']}" for err in exc.errors()
        )
        raise ConfigError(f"invalid navigation settings: {problems}") from exc
