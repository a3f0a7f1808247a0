"""Process settings from the environment, validated at start-up (fail fast, clear errors)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Literal

import platformdirs
from pydantic import BeforeValidator, Field

from robot_mcp_kit.motion_settings import MotionServerSettings
from robot_mcp_kit.settings_fields import RosName, StatePath, lower_case, settings_from_environ

DEFAULT_PORT = 9102
APP_NAME = "robot-mcp-manipulation"


def default_outbox_path() -> Path:
    """The outbox lives in the per-user data dir, never the working directory."""
    return platformdirs.user_data_path(APP_NAME) / "outbox.sqlite3"


class ConfigError(ValueError):
    """The environment does not describe a valid configuration."""


class ManipulationSettings(MotionServerSettings):
    pick_action: RosName = Field(default="/manipulation/pick", alias="MANIP_PICK_ACTION")
    place_action: RosName = Field(default="/manipulation/place", alias="MANIP_PLACE_ACTION")
    held_topic: RosName = Field(default="/manipulation/held", alias="MANIP_HELD_TOPIC")
    server_timeout_s: float = Field(default=5.0, gt=0.0, le=120.0, alias="MANIP_SERVER_TIMEOUT_S")
    cancel_timeout_s: float = Field(default=5.0, gt=0.0, le=60.0, alias="MANIP_CANCEL_TIMEOUT_S")
    task_timeout_s: float = Field(default=60.0, gt=0.0, le=3600.0, alias="MANIP_TASK_TIMEOUT_S")
    max_age_s: float = Field(default=0.0, ge=0.0, le=3600.0, alias="MANIP_MAX_DETECTION_AGE_S")
    # issue 27: the brain's lease (required: no motion without a fresh one) and this server's
    # own dead-man lock (never two publishers on one lock topic: navigation has the plain one)
    supervision: Annotated[Literal["required", "off"], BeforeValidator(lower_case)] = Field(
        default="required", alias="MANIP_SUPERVISION"
    )
    lock_topic: RosName = Field(
        default="/robot/supervisor_lock/manipulation", alias="MANIP_LOCK_TOPIC"
    )
    lock_hz: float = Field(default=20.0, ge=10.0, le=100.0, alias="MANIP_LOCK_HZ")
    lease_max_ttl_s: float = Field(default=2.0, gt=0.0, le=10.0, alias="MANIP_LEASE_MAX_TTL_S")
    # issue 35: Pick/Place clients besides this server that may be on the graph while the stop
    # holds (node names, comma-separated)
    goal_clients: str = Field(default="", max_length=1000, alias="MANIP_GOAL_CLIENTS")
    outbox_path: StatePath = Field(default_factory=default_outbox_path, alias="MANIP_OUTBOX")
    port: int = Field(default=DEFAULT_PORT, ge=1, le=65535, alias="MCP_PORT")


def load_settings(environ: Mapping[str, str]) -> ManipulationSettings:
    """Settings from an environment mapping; a bad value raises ConfigError naming it."""
    return settings_from_environ(ManipulationSettings, environ, "manipulation", ConfigError)
