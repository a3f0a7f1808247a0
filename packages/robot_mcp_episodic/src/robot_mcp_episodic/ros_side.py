"""The recorder's ROS side: graph discovery of the skills' topics, message -> domain
conversions (pure) and :class:`RosRecorder`, whose callbacks hand each message to the indexer
(memory only) and to the MCAP recorder (an in-memory chunk), so a slow disk never holds up the
ROS executor.

Followed: every ``/vision/<skill>/detections_meta`` (VisionDetectionArray; never
``/detections``, which carries masks, nor ``/overlay``) and every ``/vision/<skill>/<output>``
StampedString, as they appear in the graph (the same rule as the perception buffer), plus the
pose topic (geometry_msgs/PoseWithCovarianceStamped).
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import structlog

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.ingest import Indexer
from robot_ros_bridge import RosBridge

logger = structlog.get_logger(__name__)

META_TYPE = "ros2_vision_interfaces/msg/VisionDetectionArray"
OUTPUT_TYPE = "ros2_vision_interfaces/msg/StampedString"
POSE_TYPE = "geometry_msgs/msg/PoseWithCovarianceStamped"
NAMESPACE = "/vision/"
NOT_OUTPUTS = ("detections", "detections_meta", "overlay")


def skill_topics(topics: Mapping[str, Sequence[str]]) -> dict[str, tuple[str, str, str]]:
    """``{topic: (skill, leaf, type)}`` of the vision topics to record."""
    found: dict[str, tuple[str, str, str]] = {}
    for topic, types in topics.items():
        if not topic.startswith(NAMESPACE):
            continue
        parts = topic[len(NAMESPACE) :].split("/")
        if len(parts) != 2 or not all(parts):
            continue
        skill, leaf = parts
        if leaf == "detections_meta" and META_TYPE in types:
            found[topic] = (skill, leaf, META_TYPE)
        elif leaf not in NOT_OUTPUTS and OUTPUT_TYPE in types:
            found[topic] = (skill, leaf, OUTPUT_TYPE)
    return found


def stamp_seconds(header: Any, fallback: Callable[[], float] = time.time) -> float:
    stamp = float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9
    return stamp if stamp > 0 else fallback()


def detections_from_msg(msg: Any) -> list[dict[str, Any]]:
    return [
        {
            "label": det.label,
            "score": float(det.score),
            "box": {
                "x": int(det.box.x_offset),
                "y": int(det.box.y_offset),
                "width": int(det.box.width),
                "height": int(det.box.height),
            },
        }
        for det in msg.detections
    ]


def value_from_msg(msg: Any) -> Any:
    try:
        return json.loads(msg.data)
    except json.JSONDecodeError:
        return msg.data


def yaw_from_quaternion(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class RosRecorder:
    """Graph polling -> subscriptions -> indexer + bags. ``sync()`` is one poll."""

    def __init__(
        self,
        bridge: RosBridge,
        indexer: Indexer,
        bags: BagRecorder | None,
        pose_topic: str,
    ) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.serialization import serialize_message
        from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

        self._types = {
            META_TYPE: VisionDetectionArray,
            OUTPUT_TYPE: StampedString,
            POSE_TYPE: PoseWithCovarianceStamped,
        }
        self._serialize = serialize_message
        # Best effort matches reliable and best-effort publishers alike.
        self._qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
        self._bridge = bridge
        self._indexer = indexer
        self._bags = bags
        self._lock = threading.Lock()
        self._subs: dict[str, Any] = {}
        self.pose_topic = pose_topic
        self.received = 0
        self._subs[pose_topic] = bridge.create_subscription(
            PoseWithCovarianceStamped, pose_topic, self._on_pose, self._qos
        )

    def followed(self) -> list[str]:
        with self._lock:
            return sorted(self._subs)

    def sync(self) -> None:
        for topic, (skill, leaf, type_name) in skill_topics(
            self._bridge.topic_names_and_types()
        ).items():
            with self._lock:
                if topic in self._subs:
                    continue
                callback = (
                    self._on_meta(topic, skill)
                    if type_name == META_TYPE
                    else self._on_output(topic, skill, leaf)
                )
                self._subs[topic] = self._bridge.create_subscription(
                    self._types[type_name], topic, callback, self._qos
                )
            logger.info("episodic_subscribed", topic=topic, skill=skill)

    def close(self) -> None:
        with self._lock:
            for sub in self._subs.values():
                self._bridge.destroy_subscription(sub)
            self._subs.clear()

    def _record(self, topic: str, type_name: str, msg: Any, stamp: float) -> None:
        self.received += 1
        if self._bags is not None:
            self._bags.write(topic, type_name, self._serialize(msg), int(stamp * 1e9))

    def _on_meta(self, topic: str, skill: str) -> Callable[[Any], None]:
        def callback(msg: Any) -> None:
            stamp = stamp_seconds(msg.header)
            self._indexer.on_detections(skill, stamp, detections_from_msg(msg))
            self._record(topic, META_TYPE, msg, stamp)

        return callback

    def _on_output(self, topic: str, skill: str, output: str) -> Callable[[Any], None]:
        def callback(msg: Any) -> None:
            stamp = stamp_seconds(msg.header)
            self._indexer.on_output(skill, output, stamp, value_from_msg(msg))
            self._record(topic, OUTPUT_TYPE, msg, stamp)

        return callback

    def _on_pose(self, msg: Any) -> None:
        stamp = stamp_seconds(msg.header)
        pose = msg.pose.pose
        self._indexer.on_pose(
            stamp, float(pose.position.x), float(pose.position.y),
            yaw_from_quaternion(pose.orientation),
        )  # fmt: skip
        self._record(self.pose_topic, POSE_TYPE, msg, stamp)
