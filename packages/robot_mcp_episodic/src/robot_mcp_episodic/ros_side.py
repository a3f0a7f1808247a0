"""The recorder's ROS side: graph discovery of the skills' topics, message -> domain
conversions (pure) and :class:`RosRecorder`, whose callbacks hand each message to the MCAP
recorder (an in-memory chunk) and to the indexer (memory only), so a slow disk never holds up
the ROS executor.

Subscriptions are raw: every message goes to the MCAP as the CDR bytes that arrived (no
decode, no re-encode), and only a sample is decoded for the index — at most ``index_hz`` frames
per skill topic and ``pose_hz`` poses a second. Decoding into Python objects is what costs CPU
in rclpy; intervals (merged over a 10 s gap) and the pose track (0.25 m / 15° / 10 s) need no
more. A label seen in a single frame between two samples is in the MCAP, not in the index.
The newest pose held back by the sampling is decoded once it is due (:meth:`RosRecorder.
catch_up`, from the worker): AMCL publishes only while the robot moves, so the pose the robot
stopped at may be the last message for a long time and must not be the one skipped.

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
        *,
        index_hz: float = 2.0,
        pose_hz: float = 5.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.serialization import deserialize_message
        from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

        self._types = {
            META_TYPE: VisionDetectionArray,
            OUTPUT_TYPE: StampedString,
            POSE_TYPE: PoseWithCovarianceStamped,
        }
        self._deserialize = deserialize_message
        self._index_period = 1.0 / index_hz
        self._pose_period = 1.0 / pose_hz
        self._clock = clock
        self._next_decode: dict[str, float] = {}
        # The pose: best effort matches reliable and best-effort publishers alike.
        self._qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
        self._bridge = bridge
        self._indexer = indexer
        self._bags = bags
        self._lock = threading.Lock()
        self._pose_lock = threading.Lock()  # executor thread vs the worker's catch_up
        self._held_pose: bytes | None = None
        self._subs: dict[str, Any] = {}
        self.pose_topic = pose_topic
        self.received = 0
        self._subs[pose_topic] = bridge.create_subscription(
            PoseWithCovarianceStamped, pose_topic, self._on_pose, self._qos, raw=True
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
                # the vision node latches each result (transient local): matching its QoS
                # still gets the last result of a skill that ends before the next graph poll
                qos = self._bridge.offered_qos(topic, depth=50)
                self._subs[topic] = self._bridge.create_subscription(
                    self._types[type_name], topic, callback, qos, raw=True
                )
            logger.info("episodic_subscribed", topic=topic, skill=skill)

    def close(self) -> None:
        with self._lock:
            for sub in self._subs.values():
                self._bridge.destroy_subscription(sub)
            self._subs.clear()

    def _decode(self, topic: str, type_name: str, data: bytes, period: float) -> Any | None:
        """The decoded message if this topic's next sample is due, else None."""
        now = self._clock()
        if now < self._next_decode.get(topic, 0.0):
            return None
        self._next_decode[topic] = now + period
        return self._deserialize(data, self._types[type_name])

    def _record(self, topic: str, type_name: str, data: bytes) -> None:
        """To the MCAP with the receive time as log time (as rosbag2 does); the message keeps
        its own header stamp."""
        self.received += 1
        if self._bags is not None:
            self._bags.write(topic, type_name, data)

    def _on_meta(self, topic: str, skill: str) -> Callable[[bytes], None]:
        def callback(data: bytes) -> None:
            msg = self._decode(topic, META_TYPE, data, self._index_period)
            if msg is not None:
                self._indexer.on_detections(
                    skill, stamp_seconds(msg.header), detections_from_msg(msg)
                )
            self._record(topic, META_TYPE, data)

        return callback

    def _on_output(self, topic: str, skill: str, output: str) -> Callable[[bytes], None]:
        def callback(data: bytes) -> None:
            msg = self._deserialize(data, self._types[OUTPUT_TYPE])  # outputs are rare: all
            self._indexer.on_output(skill, output, stamp_seconds(msg.header), value_from_msg(msg))
            self._record(topic, OUTPUT_TYPE, data)

        return callback

    def _on_pose(self, data: bytes) -> None:
        with self._pose_lock:
            msg = self._decode(self.pose_topic, POSE_TYPE, data, self._pose_period)
            self._held_pose = None if msg is not None else data
            if msg is not None:
                self._index_pose(msg)
        self._record(self.pose_topic, POSE_TYPE, data)

    def catch_up(self) -> None:
        """Index the newest pose the sampling held back, once a sample is due (the worker
        calls this every pose period): the last pose before the publisher went quiet."""
        with self._pose_lock:
            held = self._held_pose
            if held is None:
                return
            msg = self._decode(self.pose_topic, POSE_TYPE, held, self._pose_period)
            if msg is not None:
                self._held_pose = None
                self._index_pose(msg)

    def _index_pose(self, msg: Any) -> None:
        pose = msg.pose.pose
        self._indexer.on_pose(
            stamp_seconds(msg.header), float(pose.position.x), float(pose.position.y),
            yaw_from_quaternion(pose.orientation),
        )  # fmt: skip
