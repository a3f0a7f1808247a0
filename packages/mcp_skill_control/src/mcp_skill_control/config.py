"""Start-up configuration (spec 001 §6), validated by Pydantic before anything starts."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, field_validator

DEFAULT_PORT = 9201
DEFAULT_CATALOG = Path(__file__).resolve().parent / "config" / "skills.yaml"


class SkillControlConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    vision_node_name: str = Field(default="vision_node", min_length=1)
    skills_catalog: Path = DEFAULT_CATALOG
    call_timeout_s: float = Field(default=5.0, gt=0, le=120)
    """Deadline of one VisionTask service call, discovery included."""
    wait_for_service_s: float = Field(default=3.0, ge=0, le=60)
    """How long a call tolerates a not-yet-discovered vision node before service_unavailable."""
    reconcile_s: float = Field(default=5.0, ge=0, le=120)
    """After a create timeout: how long to look for the skill in the node's list (adopt it)."""
    orphan_sweep_s: float = Field(default=60.0, ge=0, le=3600)
    """After an unconfirmed create: how long a late-appearing skill is still removed."""
    ros_node_name: str = "mcp_skill_control"
    log_level: str = "INFO"

    @field_validator("skills_catalog")
    @classmethod
    def _catalog_exists(cls, value: Path) -> Path:
        if not value.is_file():
            raise ValueError(f"SKILLS_CATALOG {value} is not a file")
        return value

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> SkillControlConfig:
        env = os.environ if env is None else env
        values: dict[str, object] = {}
        for field_name, var in (
            ("vision_node_name", "VISION_NODE_NAME"),
            ("skills_catalog", "SKILLS_CATALOG"),
            ("call_timeout_s", "SKILL_CONTROL_CALL_TIMEOUT_S"),
            ("wait_for_service_s", "SKILL_CONTROL_WAIT_FOR_SERVICE_S"),
            ("reconcile_s", "SKILL_CONTROL_RECONCILE_S"),
            ("orphan_sweep_s", "SKILL_CONTROL_ORPHAN_SWEEP_S"),
            ("ros_node_name", "SKILL_CONTROL_ROS_NODE_NAME"),
            ("log_level", "LOG_LEVEL"),
        ):
            if env.get(var):
                values[field_name] = env[var]
        return cls.model_validate(values)
