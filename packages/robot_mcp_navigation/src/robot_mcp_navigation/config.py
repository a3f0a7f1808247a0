"""Process settings from the environment, validated at start-up (fail fast, clear errors)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Literal

import platformdirs
from pydantic import BeforeValidator, Field

from robot_mcp_kit.motion_settings import MotionServerSettings
from robot_mcp_kit.settings_fields import RosName, StatePath, lower_case, settings_from_environ

DEFAULT_PORT = 9101
APP_NAME = "robot-mcp-navigation"


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


class NavigationSettings(MotionServerSettings):
    map_path: Path = Field(default_factory=default_map_path, alias="NAV_MAP")
    motion: Annotated[Literal["simulated", "nav2"], BeforeValidator(lower_case)] = Field(
        default="simulated", alias="NAV_MOTION"
    )
    nav2_action: RosName = Field(default="/navigate_to_pose", alias="NAV2_ACTION")
    pose_topic: RosName = Field(default="/amcl_pose", alias="NAV_POSE_TOPIC")
    map_topic: RosName = Field(default="/map", alias="NAV_MAP_TOPIC")
    costmap_topic: RosName = Field(default="/global_costmap/costmap", alias="NAV_COSTMAP_TOPIC")
    plan_topic: RosName = Field(default="/plan", alias="NAV_PLAN_TOPIC")
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
    outbox_path: StatePath = Field(default_factory=default_outbox_path, alias="NAV_OUTBOX")
    pose_path: StatePath = Field(default_factory=default_pose_path, alias="NAV_POSE_PATH")
    port: int = Field(default=DEFAULT_PORT, ge=1, le=65535, alias="MCP_PORT")
    # elicit: ask the MCP client's person to confirm each navigate_to (third-party hosts)
    confirm_motion: Literal["off", "elicit"] = Field(default="off", alias="NAV_CONFIRM_MOTION")
    # issue 27: the brain's lease (required: no motion without a fresh one) and the dead-man
    # lock on the robot's twist_mux (published with NAV_MOTION=nav2 and required supervision)
    supervision: Annotated[Literal["required", "off"], BeforeValidator(lower_case)] = Field(
        default="required", alias="NAV_SUPERVISION"
    )
    lock_topic: RosName = Field(default="/robot/supervisor_lock", alias="NAV_LOCK_TOPIC")
    lock_hz: float = Field(default=20.0, ge=10.0, le=100.0, alias="NAV_LOCK_HZ")
    lease_max_ttl_s: float = Field(default=2.0, gt=0.0, le=10.0, alias="NAV_LEASE_MAX_TTL_S")
    nav2_feedback_timeout_s: float = Field(
        default=3.0, ge=0.0, le=60.0, alias="NAV2_FEEDBACK_TIMEOUT_S"
    )
    pose_max_age_s: float = Field(default=0.0, ge=0.0, le=3600.0, alias="NAV_POSE_MAX_AGE_S")
    # issue 35: NavigateToPose clients besides this server that may be on the graph while the
    # stop holds (node names, comma-separated; e.g. Nav2's waypoint_follower on a robot)
    goal_clients: str = Field(default="", max_length=1000, alias="NAV_GOAL_CLIENTS")


def load_settings(environ: Mapping[str, str]) -> NavigationSettings:
    """Settings from an environment mapping; a bad value raises ConfigError naming it."""
    return settings_from_environ(NavigationSettings, environ, "navigation", ConfigError)
