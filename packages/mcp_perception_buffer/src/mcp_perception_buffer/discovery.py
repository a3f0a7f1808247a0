"""Which ``/vision/**`` topics belong to which skill (pure; fed by ROS graph polling).

Only ``/vision/{skill}/detections_meta`` (VisionDetectionArray) and
``/vision/{skill}/{output}`` (StampedString) are read; ``/detections`` (masks) and
``/overlay`` (pixels) never are.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

META_TYPE = "ros2_vision_interfaces/msg/VisionDetectionArray"
OUTPUT_TYPE = "ros2_vision_interfaces/msg/StampedString"
NAMESPACE = "/vision"


@dataclass(frozen=True)
class SkillTopics:
    skill: str
    meta: str | None = None
    outputs: Mapping[str, str] = field(default_factory=dict)

    def all(self) -> list[str]:
        return ([self.meta] if self.meta else []) + sorted(self.outputs.values())


def skills_in_graph(
    topics: Mapping[str, Sequence[str]], namespace: str = NAMESPACE
) -> dict[str, SkillTopics]:
    """Group the graph's ``{topic: [types]}`` into the skills the buffer should follow."""
    prefix = namespace.rstrip("/") + "/"
    metas: dict[str, str] = {}
    outputs: dict[str, dict[str, str]] = {}
    for topic, types in topics.items():
        if not topic.startswith(prefix):
            continue
        parts = topic[len(prefix) :].split("/")
        if len(parts) != 2 or not all(parts):
            continue
        skill, leaf = parts
        if leaf == "detections_meta" and META_TYPE in types:
            metas[skill] = topic
        elif leaf not in ("detections", "detections_meta", "overlay") and OUTPUT_TYPE in types:
            outputs.setdefault(skill, {})[leaf] = topic
    return {
        skill: SkillTopics(skill, metas.get(skill), outputs.get(skill, {}))
        for skill in sorted(set(metas) | set(outputs))
    }
