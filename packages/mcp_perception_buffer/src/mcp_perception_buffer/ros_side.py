"""The ROS side of the buffer: message -> domain conversion (pure functions) and the
:class:`TopicFollower`, which keeps one subscription per discovered skill topic.

A topic is followed while it has publishers; a skill whose topics all lost their publishers
for ``gone_grace_s`` is unsubscribed. Subscriptions copy the publisher's reliability and
durability (a transient-local publisher's last result is received even when the buffer
subscribes after it was published).

Skill incarnations: every buffered entry carries its publisher's GID. When a publisher of a
skill leaves the graph (the skill was stopped, possibly to be re-created under the same
name), its entries are retired at once and its late messages ignored, so a new skill of the
same name is never served the old one's results. This is checked on every graph poll and on
every read of the skill (:meth:`TopicFollower.refresh`).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from typing import Any

import structlog

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.discovery import SkillTopics, skills_in_graph
from robot_ros_bridge import RosBridge

logger = structlog.get_logger(__name__)


# -- conversions (pure) ------------------------------------------------------------------
def stamp_seconds(header: Any) -> float:
    return float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9


def decode_extra(text: str) -> dict[str, Any]:
    if not text:
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return {"raw": text[:200]}
    return value if isinstance(value, dict) else {"value": value}


def detections_from_msg(msg: Any) -> tuple[float, list[dict[str, Any]]]:
    """A VisionDetectionArray as ``(stamp, [detection dicts])``; mask pixels are never read."""
    detections = [
        {
            "label": det.label,
            "score": round(float(det.score), 4),
            "kind": det.kind or "object",
            "box": {
                "x": int(det.box.x_offset),
                "y": int(det.box.y_offset),
                "width": int(det.box.width),
                "height": int(det.box.height),
            },
            "point": {"x": float(det.point.x), "y": float(det.point.y)},
            "extra": decode_extra(det.extra),
        }
        for det in msg.detections
    ]
    return stamp_seconds(msg.header), detections


def result_extra_from_msg(msg: Any) -> dict[str, Any]:
    """The array-level JSON ``extra`` (nodes built before that field existed have none)."""
    return decode_extra(str(getattr(msg, "extra", "") or ""))


def value_from_msg(msg: Any) -> tuple[float, Any]:
    """A StampedString as ``(stamp, value)``; ``data`` is the JSON encoding of the value."""
    try:
        value = json.loads(msg.data)
    except json.JSONDecodeError:
        value = msg.data
    return stamp_seconds(msg.header), value


def publisher_gid(info: Any) -> bytes | None:
    """The publisher GID of an rclpy ``MessageInfo`` (same bytes as ``endpoint_gid``)."""
    gid = info.get("publisher_gid") if isinstance(info, dict) else None
    data = gid.get("data") if isinstance(gid, dict) else None
    return bytes(data) if data is not None else None


# -- subscriptions -----------------------------------------------------------------------
class TopicFollower:
    """Graph polling -> subscriptions -> buffer writes. ``sync()`` is one poll."""

    def __init__(
        self,
        bridge: RosBridge,
        buffer: RollingBuffer,
        *,
        gone_grace_s: float = 2.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

        self._meta_type = VisionDetectionArray
        self._output_type = StampedString
        self._bridge = bridge
        self._buffer = buffer
        self._grace = gone_grace_s
        self._clock = clock
        self._lock = threading.Lock()
        self._subs: dict[str, dict[str, Any]] = {}  # skill -> topic -> subscription
        self._silent_since: dict[str, float] = {}
        self._live: dict[str, set[bytes]] = {}  # skill -> publisher GIDs seen in the graph
        self._retired: dict[str, set[bytes]] = {}  # skill -> publisher GIDs that left

    def followed(self) -> dict[str, list[str]]:
        with self._lock:
            return {skill: sorted(subs) for skill, subs in self._subs.items()}

    def sync(self) -> None:
        """Subscribe to new skill topics; retire gone publishers; drop skills gone for good."""
        graph = skills_in_graph(self._bridge.topic_names_and_types())
        now = self._clock()
        with self._lock:
            for skill, topics in graph.items():
                # a skill not followed yet is followed once it publishes: its topics can stay in
                # the graph without publishers (another reader, e.g. the episodic recorder, keeps
                # them there after the skill stopped), and following those dropped and
                # re-subscribed them every grace period, for as long as the reader lived
                if skill in self._subs or self._publishes(topics):
                    self._follow(skill, topics)
            for skill in list(self._subs):
                if self._reconcile(skill):
                    self._silent_since.pop(skill, None)
                    continue
                since = self._silent_since.setdefault(skill, now)
                if now - since >= self._grace:
                    self._unfollow(skill)

    def _publishes(self, topics: SkillTopics) -> bool:
        return any(self._bridge.publisher_count(topic) > 0 for topic in topics.all())

    def refresh(self, skill: str) -> None:
        """Retire the entries of ``skill`` whose publishers left the graph (call before a
        read, so a just-stopped or just-replaced skill's results are not served)."""
        with self._lock:
            if skill in self._subs:
                self._reconcile(skill)

    def _reconcile(self, skill: str) -> int:
        """Compare the skill's publishers with the last poll; returns how many there are."""
        current = {
            bytes(info.endpoint_gid)
            for topic in self._subs[skill]
            for info in self._bridge.node.get_publishers_info_by_topic(topic)
        }
        gone = self._live.get(skill, set()) - current
        self._live[skill] = current
        if gone:
            self._retired.setdefault(skill, set()).update(gone)
            retired = self._buffer.retire(skill, gone)
            logger.info(
                "buffer_publishers_gone", skill=skill, publishers=len(gone), entries=retired
            )
        return len(current)

    def close(self) -> None:
        with self._lock:
            for skill in list(self._subs):
                self._unfollow(skill, drop=False)

    def _follow(self, skill: str, topics: SkillTopics) -> None:
        subs = self._subs.setdefault(skill, {})
        if topics.meta and topics.meta not in subs:
            subs[topics.meta] = self._bridge.create_subscription(
                self._meta_type, topics.meta, self._on_meta(skill), self._qos(topics.meta)
            )
            logger.info("buffer_subscribed", skill=skill, topic=topics.meta)
        for output, topic in topics.outputs.items():
            if topic not in subs:
                subs[topic] = self._bridge.create_subscription(
                    self._output_type, topic, self._on_output(skill, output), self._qos(topic)
                )
                logger.info("buffer_subscribed", skill=skill, topic=topic)

    def _unfollow(self, skill: str, *, drop: bool = True) -> None:
        for sub in self._subs.pop(skill, {}).values():
            self._bridge.destroy_subscription(sub)
        self._silent_since.pop(skill, None)
        self._live.pop(skill, None)
        self._retired.pop(skill, None)
        if drop:
            self._buffer.drop(skill)
            logger.info("buffer_dropped", skill=skill, reason="topics_gone")

    def _qos(self, topic: str) -> Any:
        return self._bridge.offered_qos(topic)

    def _source(self, skill: str, info: Any) -> tuple[bytes | None, bool]:
        """``(publisher GID, accept)``: a message from a publisher that left is dropped."""
        gid = publisher_gid(info)
        with self._lock:
            retired = gid is not None and gid in self._retired.get(skill, ())
        return gid, not retired

    def _on_meta(self, skill: str) -> Callable[[Any, Any], None]:
        def callback(msg: Any, info: Any) -> None:
            source, accept = self._source(skill, info)
            if accept:
                stamp, detections = detections_from_msg(msg)
                meta = result_extra_from_msg(msg)
                self._buffer.add_result(skill, stamp, detections, source, meta)

        return callback

    def _on_output(self, skill: str, output: str) -> Callable[[Any, Any], None]:
        def callback(msg: Any, info: Any) -> None:
            source, accept = self._source(skill, info)
            if accept:
                stamp, value = value_from_msg(msg)
                self._buffer.add_output(skill, output, value, stamp, source)

        return callback
