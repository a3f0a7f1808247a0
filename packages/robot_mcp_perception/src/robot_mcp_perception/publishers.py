"""Per-skill ROS publisher sets, created and destroyed with the skill (spec 000 §6.1).

QoS of every per-skill topic: RELIABLE, TRANSIENT_LOCAL, depth 1 — a consumer that joins
late (e.g. a once-skill reader) still gets the last result; VOLATILE subscribers also match.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray
from sensor_msgs.msg import Image as ImageMsg
from std_msgs.msg import Header

from robot_mcp_perception.conversions import (
    detections_to_msg,
    frame_header,
    output_to_msg,
    rgb_to_image_msg,
)
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.models.base import Image
from robot_mcp_perception.pipelines.common import SkillResult
from robot_mcp_perception.registry import SkillTopics

if TYPE_CHECKING:
    from rclpy.node import Node

RESULT_QOS = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    history=HistoryPolicy.KEEP_LAST,
)
DIAGNOSTICS_QOS = QoSProfile(
    depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST
)


class SkillPublishers:
    """detections (masks), detections_meta (no masks), one StampedString per output, overlay."""

    def __init__(self, node: Node, skill_name: str, topics: SkillTopics) -> None:
        self.skill_name = skill_name
        self.topics = topics
        self._node = node
        self._lock = threading.Lock()
        self._closed = False
        self.detections = node.create_publisher(VisionDetectionArray, topics.detections, RESULT_QOS)
        self.detections_meta = node.create_publisher(
            VisionDetectionArray, topics.detections_meta, RESULT_QOS
        )
        self.overlay = node.create_publisher(ImageMsg, topics.overlay, RESULT_QOS)
        self.outputs = {
            name: node.create_publisher(StampedString, topic, RESULT_QOS)
            for name, topic in topics.outputs.items()
        }

    def publish(
        self,
        frame: Frame,
        result: SkillResult,
        extras: list[dict[str, Any]],
        render_overlay: Callable[[], Image] | None,
        result_extra: dict[str, Any] | None = None,
        outputs_header: Header | None = None,
    ) -> bool:
        """Publish one result; False if the publishers were already destroyed.

        ``outputs_header`` stamps the semantic outputs when they come from another frame than
        the detections (a re-used grounding); by default they share the frame's header."""
        header = frame_header(frame)
        with self._lock:
            if self._closed:
                return False
            self.detections.publish(
                detections_to_msg(
                    self.skill_name,
                    result.detections,
                    header,
                    with_masks=True,
                    extras=extras,
                    result_extra=result_extra,
                )
            )
            self.detections_meta.publish(
                detections_to_msg(
                    self.skill_name,
                    result.detections,
                    header,
                    with_masks=False,
                    extras=extras,
                    result_extra=result_extra,
                )
            )
            for name, publisher in self.outputs.items():
                if name in result.outputs:
                    publisher.publish(output_to_msg(result.outputs[name], outputs_header or header))
            if render_overlay is not None and self.overlay.get_subscription_count() > 0:
                self.overlay.publish(rgb_to_image_msg(render_overlay(), header))
        return True

    def destroy(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            for publisher in (
                self.detections,
                self.detections_meta,
                self.overlay,
                *self.outputs.values(),
            ):
                self._node.destroy_publisher(publisher)
