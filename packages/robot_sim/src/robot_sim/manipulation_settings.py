"""The gripper's settings (no ROS imports: config.py builds them from the environment)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ManipulationSettings:
    pick_action: str = "/manipulation/pick"
    place_action: str = "/manipulation/place"
    held_topic: str = "/manipulation/held"
    pick_s: float = 3.0
    """Robot seconds a pick takes (four phases); wall time = this / time_scale."""
    place_s: float = 2.0
    time_scale: float = 1.0
    discovery_hz: float = 5.0
    """How often the graph is read for new ``/vision/*/detections`` topics."""
