"""A skill that publishes its only result and ends before the recorder's next graph poll
(a find that the prewarmed grounding answers at once) is still recorded: the vision node
latches each result (reliable, transient local), and the recorder subscribes with the QoS
its publisher offers, so joining after the publish still delivers that result."""

from __future__ import annotations

import time
import uuid
from pathlib import Path

import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_mcp_episodic.ingest import Indexer
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.ros_side import RosRecorder
from robot_mcp_episodic.store.base import EpisodicStore
from robot_ros_bridge import RosBridge
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros

# the vision node's per-skill result QoS (robot_mcp_perception.publishers.RESULT_QOS)
LATCHED = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


def detections(label: str) -> object:
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

    msg = VisionDetectionArray()
    now = time.time()
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(now), int(now % 1 * 1e9)
    detection = VisionDetection()
    detection.label, detection.score, detection.kind = label, 0.9, "object"
    detection.box.x_offset, detection.box.y_offset = 10, 20
    detection.box.width, detection.box.height = 30, 40
    msg.detections = [detection]
    return msg


def test_a_result_published_before_the_recorder_subscribed_is_recorded(
    sqlite_store: EpisodicStore, places: Places, tmp_path: Path
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    skill = f"find_{uuid.uuid4().hex[:8]}"
    topic = f"/vision/{skill}/detections_meta"
    indexer = Indexer(sqlite_store, places)
    with RosBridge(f"vision_{skill}") as vision, RosBridge(f"episodic_{skill}") as episodic:
        publisher = vision.create_publisher(VisionDetectionArray, topic, LATCHED)
        publisher.publish(detections("yellow package"))  # the skill's one and only result
        recorder = RosRecorder(episodic, indexer, None, "/amcl_pose")
        wait_until(
            lambda: topic in episodic.topic_names_and_types(), 10, "the skill's topic in the graph"
        )
        recorder.sync()  # the graph poll comes after the publish
        assert topic in recorder.followed()

        def recorded() -> bool:
            indexer.flush()
            return bool(sqlite_store.sightings(0, time.time() + 60, labels=["yellow package"]))

        wait_until(recorded, 10, "the latched result recorded")
        recorder.close()
    (sighting,) = sqlite_store.sightings(0, time.time() + 60, labels=["yellow package"])
    assert sighting.skill == skill
