"""Process settings from the environment, validated at start-up (fail fast, clear errors)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

import platformdirs
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator

from robot_mcp_kit.settings_fields import (
    LogLevel,
    RosName,
    StatePath,
    empty_is_none,
    settings_from_environ,
)
from robot_sim.manipulation_settings import ManipulationSettings

APP_NAME = "robot-sim"
BASE_LOCK_TOPIC = "/robot/supervisor_lock"
"""The navigation server's dead-man lock (``NAV_LOCK_TOPIC``): the base's twist_mux lock."""
ARM_LOCK_TOPIC = "/robot/supervisor_lock/manipulation"
"""The manipulation server's dead-man lock (``MANIP_LOCK_TOPIC``): the arm controller's gate."""


def default_world_path() -> Path:
    """The office world shipped with the package (``config/worlds/office.yaml``)."""
    return Path(__file__).resolve().parents[2] / "config" / "worlds" / "office.yaml"


def default_scenes_dir() -> Path:
    return platformdirs.user_cache_path(APP_NAME) / "scenes"


class ConfigError(ValueError):
    """The environment does not describe a valid configuration."""


class SimSettings(BaseModel):
    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)

    world_path: Path = Field(default_factory=default_world_path, alias="SIM_WORLD")
    map_path: Annotated[Path | None, BeforeValidator(empty_is_none)] = Field(
        default=None, alias="SIM_MAP"
    )
    scenes_dir: StatePath = Field(default_factory=default_scenes_dir, alias="SIM_SCENES_DIR")
    time_scale: float = Field(default=1.0, gt=0.0, le=1000.0, alias="SIM_TIME_SCALE")
    failures_enabled: bool = Field(default=True, alias="SIM_FAILURES")
    action_name: RosName = Field(default="/navigate_to_pose", alias="SIM_ACTION")
    camera_topic: RosName = Field(default="/camera/image_raw", alias="SIM_CAMERA_TOPIC")
    camera_info_topic: RosName = Field(default="/camera/camera_info", alias="SIM_CAMERA_INFO_TOPIC")
    depth_topic: RosName = Field(default="/camera/depth/image_raw", alias="SIM_DEPTH_TOPIC")
    scenes_keep: int = Field(default=64, ge=4, le=10_000, alias="SIM_SCENES_KEEP")
    moving_render_scale: float = Field(default=0.5, ge=0.1, le=1.0, alias="SIM_RENDER_SCALE_MOVING")
    camera_frame_id: str = Field(default="camera_optical_frame", alias="SIM_CAMERA_FRAME")
    camera_fps: float = Field(default=5.0, gt=0.0, le=30.0, alias="SIM_CAMERA_FPS")
    pose_hz: float = Field(default=20.0, ge=10.0, le=100.0, alias="SIM_POSE_HZ")
    feedback_hz: float = Field(default=10.0, gt=0.0, le=50.0, alias="SIM_FEEDBACK_HZ")
    ready_file: Annotated[Path | None, BeforeValidator(empty_is_none)] = Field(
        default=None, alias="SIM_READY_FILE"
    )
    pick_action: RosName = Field(default="/manipulation/pick", alias="SIM_PICK_ACTION")
    place_action: RosName = Field(default="/manipulation/place", alias="SIM_PLACE_ACTION")
    held_topic: RosName = Field(default="/manipulation/held", alias="SIM_HELD_TOPIC")
    pick_s: float = Field(default=3.0, gt=0.0, le=120.0, alias="SIM_PICK_S")
    place_s: float = Field(default=2.0, gt=0.0, le=120.0, alias="SIM_PLACE_S")
    pick_max_age_s: float = Field(default=30.0, gt=0.0, le=3600.0, alias="SIM_PICK_MAX_AGE_S")
    # issue 27: honour the motion servers' dead-man locks like a robot's twist_mux (on in the
    # local stack, whose navigation server publishes one; off for robot-sim driven alone)
    supervisor_lock: bool = Field(default=False, alias="SIM_SUPERVISOR_LOCK")
    # the base's locks (twist_mux in front of the base controller)
    supervisor_lock_topics: tuple[RosName, ...] = Field(
        default=(BASE_LOCK_TOPIC,), alias="SIM_SUPERVISOR_LOCK_TOPICS"
    )
    # issue 39: the arm's locks (its controller's command gate): the manipulation server's
    arm_lock_topics: tuple[RosName, ...] = Field(
        default=(ARM_LOCK_TOPIC,), alias="SIM_ARM_LOCK_TOPICS"
    )
    supervisor_lock_timeout_s: float = Field(
        default=0.5, gt=0.0, le=5.0, alias="SIM_SUPERVISOR_LOCK_TIMEOUT_S"
    )
    # Nav2's movement_time_allowance: a goal whose base the lock holds this long is aborted
    progress_timeout_s: float = Field(
        default=10.0, gt=0.0, le=600.0, alias="SIM_PROGRESS_TIMEOUT_S"
    )
    # every thread's stack to stderr when the pose timer stood still this long (0: off)
    stall_dump_s: float = Field(default=3.0, ge=0.0, le=600.0, alias="SIM_STALL_DUMP_S")
    log_level: LogLevel = Field(default="INFO", alias="LOG_LEVEL")

    @field_validator("supervisor_lock_topics", "arm_lock_topics", mode="before")
    @classmethod
    def _topic_list(cls, value: object) -> object:
        if isinstance(value, str):
            return tuple(t.strip() for t in value.split(",") if t.strip())
        return value

    @field_validator("supervisor_lock_topics", "arm_lock_topics")
    @classmethod
    def _some_lock_topic(cls, value: tuple[str, ...]) -> tuple[str, ...]:
        if not value:
            raise ValueError(
                f"comma-separated absolute ROS names such as {BASE_LOCK_TOPIC} (a part with "
                "no lock could never be stopped by supervision)"
            )
        return value

    def manipulation(self) -> ManipulationSettings:
        return ManipulationSettings(
            self.pick_action,
            self.place_action,
            self.held_topic,
            self.pick_s,
            self.place_s,
            self.time_scale,
        )


def load_settings(environ: Mapping[str, str]) -> SimSettings:
    """Settings from an environment mapping; a bad value raises ConfigError naming it."""
    return settings_from_environ(SimSettings, environ, "robot-sim", ConfigError)
