"""Pydantic models of the composed Hydra config, validated at start-up (fail fast).

The adapter blocks (``grounder``, ``segmenter``, ``frame_source``) are validated only for
the keys the node itself reads (``_target_``, ``cost_class``); the adapter's own arguments
are checked by its constructor when Hydra instantiates it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from robot_mcp_perception.skills import Skill, SkillError

ROS_PARAMETERS = (
    "camera_topic",
    "topic_namespace",
    "processing_frequency",
    "max_in_flight",
    "default_skills",
)
"""Node settings that are also ROS parameters (spec 000 §7); a ROS value overrides Hydra's."""


class StartupError(RuntimeError):
    """The node cannot start as configured; the message names the problem (exit code 2).

    The message is one line: causes that span lines (Hydra's errors do) are joined."""

    def __init__(self, message: object = "") -> None:
        super().__init__(" ".join(str(message).split()))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class AdapterSettings(BaseModel):
    model_config = ConfigDict(extra="allow", frozen=True, populate_by_name=True)

    target: str = Field(alias="_target_", min_length=1)
    cost_class: Literal["local", "cloud"] = "local"
    name: str = ""
    """The adapter's name in results (``grounder`` marker); default: the config choice."""


class GrounderChainSettings(_Strict):
    """How the fallback grounder (``fallback_grounder`` group) stands in for the primary."""

    retry_after_s: float = Field(10.0, gt=0)
    """After an outage the primary is left alone this long (doubling per further outage)."""
    max_retry_after_s: float = Field(300.0, gt=0)


class NodeSettings(_Strict):
    node_name: str = "vision_node"
    camera_topic: str = "/camera/image_raw"
    topic_namespace: str = "/vision"
    processing_frequency: float = Field(1.0, gt=0, le=30)
    """Default rate_hz of a skill that gives none."""
    max_in_flight: int = Field(4, ge=1, le=64)
    workers: int = Field(2, ge=1, le=32)
    model_timeout_s: float = Field(60.0, gt=0)
    """Time limit of one skill run (a hung model frees its worker)."""
    tick_hz: float = Field(50.0, gt=0, le=500)
    """How often due skills are checked when no new frame arrives."""
    default_skills: list[dict[str, Any]] = Field(default_factory=list)
    stats_period_s: float = Field(2.0, gt=0)
    frame_stale_after_s: float = Field(5.0, gt=0)
    """/healthz reports ``degraded`` (HTTP 503) when the newest frame arrived longer ago."""
    fresh_frame_wait_s: float = Field(3.0, ge=0, le=30)
    """A new (or re-enabled) skill's first run waits up to this long for a frame captured
    (header stamp) after the node took the skill up, so "look now" never answers from a
    frame taken before — e.g. the corridor seen while driving, for a skill started on
    arrival. Past the wait (a camera whose stamps lag the clock) it runs on the newest frame.
    0 turns the wait off."""

    @field_validator("default_skills")
    @classmethod
    def _default_skills_are_valid_skills(cls, value: list[dict[str, Any]]) -> list[dict[str, Any]]:
        names: set[str] = set()
        for index, data in enumerate(value):
            try:
                skill = Skill.from_dict(data)
            except SkillError as error:
                raise ValueError(f"skill {index}: {error.code}: {error.detail}") from error
            if skill.name in names:
                raise ValueError(f"duplicate skill name {skill.name!r}")
            names.add(skill.name)
        return value

    @field_validator("topic_namespace")
    @classmethod
    def _namespace_is_absolute(cls, value: str) -> str:
        if not value.startswith("/") or (value.endswith("/") and value != "/"):
            raise ValueError("topic_namespace must start with '/' and not end with '/'")
        return value


class AmbientSceneSettings(_Strict):
    enabled: bool = False
    name: str = "ambient_scene"
    rate_hz: float = Field(0.2, gt=0)
    grounding: str = "a brief description of the scene and the main objects"


class CostSettings(_Strict):
    max_cloud_calls_per_min: int = Field(60, ge=0)
    max_cloud_rate_hz: float = Field(1.0, gt=0)
    cloud_requires_gate: bool = True
    ambient_scene: AmbientSceneSettings = Field(default_factory=AmbientSceneSettings)


class WatchSettings(_Strict):
    gate_threshold: float = Field(0.02, ge=0)


class PrewarmSettings(_Strict):
    prewarm_ttl_s: float = Field(60.0, gt=0)


class ArtifactsSettings(_Strict):
    enabled: bool = True
    host: Literal["127.0.0.1", "localhost", "::1"] = "127.0.0.1"
    port: int = Field(9112, ge=0, le=65535)
    masks_per_skill: int = Field(8, ge=1, le=256)
    overlays_per_skill: int = Field(2, ge=1, le=32)
    deleted_skills_kept: int = Field(8, ge=0, le=256)


class LoggingSettings(_Strict):
    json_logs: bool = True
    level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = "INFO"


class PipelineBlock(_Strict):
    crop_margin: float = 0.15
    tile_grid: tuple[int, int] = (2, 2)
    tile_overlap: float = 0.1
    dedupe_radius_px: int = 12
    nms_iou: float = 0.5
    min_mask_fraction: float = 0.0005
    max_mask_fraction: float = 0.9


class PerceptionSettings(BaseModel):
    """The whole composed config."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    grounder: AdapterSettings
    fallback_grounder: AdapterSettings | None = None
    """Answers when the grounder has an outage (issue 30); None: no fallback, the node
    publishes "cannot see" instead."""
    grounder_chain: GrounderChainSettings = Field(default_factory=GrounderChainSettings)
    segmenter: AdapterSettings
    frame_source: AdapterSettings
    node: NodeSettings = Field(default_factory=NodeSettings)
    cost: CostSettings = Field(default_factory=CostSettings)
    watch: WatchSettings = Field(default_factory=WatchSettings)
    prewarm: PrewarmSettings = Field(default_factory=PrewarmSettings)
    artifacts: ArtifactsSettings = Field(default_factory=ArtifactsSettings)
    logging: LoggingSettings = Field(default_factory=LoggingSettings)
    pipeline: PipelineBlock = Field(default_factory=PipelineBlock)
    deployment: dict[str, Any] | None = None


def node_settings_with(node: NodeSettings, parameters: Mapping[str, Any]) -> NodeSettings:
    """``node`` with ROS parameter values applied, validated exactly like the Hydra config;
    a bad value is a :class:`StartupError` naming the parameter (one line)."""
    values = dict(parameters)
    if isinstance(values.get("default_skills"), str):
        values["default_skills"] = _decode_skills(values["default_skills"])
    try:
        return NodeSettings.model_validate({**node.model_dump(), **values})
    except ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()
        )
        raise StartupError(f"invalid ROS parameter: {problems}".replace("\n", " ")) from error


def _decode_skills(raw: str) -> Any:
    if not raw.strip():
        return []
    try:
        decoded = json.loads(raw)
    except ValueError as error:
        raise StartupError(f"ROS parameter default_skills is not valid JSON: {error}") from error
    if not isinstance(decoded, list):
        raise StartupError("ROS parameter default_skills must be a JSON list of skill objects")
    return decoded
