"""What the node is built from: the validated settings and the adapters behind the ports.

``composition.build_runtime`` is the only place that builds one from config; tests build one
directly with fakes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from robot_mcp_perception.artifacts import OverlayRenderer
from robot_mcp_perception.artifacts_auth import ArtifactsAuth
from robot_mcp_perception.engine import SkillRunner
from robot_mcp_perception.frames import FrameSource
from robot_mcp_perception.models.base import Grounder, Segmenter
from robot_mcp_perception.pipelines.common import PipelineSettings
from robot_mcp_perception.registry import Gate
from robot_mcp_perception.settings import PerceptionSettings

GateFactory = Callable[[float], Gate]
"""Builds a frame-difference gate from ``watch.gate_threshold``."""


@dataclass
class Runtime:
    settings: PerceptionSettings
    grounder: Grounder
    segmenter: Segmenter
    frame_source: FrameSource
    runner: SkillRunner
    gate_factory: GateFactory | None = None
    overlay_renderer: OverlayRenderer | None = None
    pipeline_settings: PipelineSettings | None = None
    serve_artifacts: bool = True
    artifacts_auth: ArtifactsAuth = field(default_factory=ArtifactsAuth)
    """Who may read pictures (default: nobody; ``composition`` reads the environment)."""
