"""The recorder's ROS side against a fake bridge (the port): every message goes to the bag,
a sample is decoded for the index, and the pose the sampling held back is indexed once due."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.ingest import Indexer
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.ros_side import RosRecorder
from robot_mcp_episodic.store.base import EpisodicStore

T = 1_790_000_000.0


class FakeBridge:
    """The RosBridge surface the recorder uses; raw callbacks are called by the test."""

    def __init__(self) -> None:
        self.callbacks: dict[str, Callable[[bytes], None]] = {}

    def create_subscription(
        self, _msg_type: Any, topic: str, callback: Callable[[bytes], None], _qos: Any, *,
        raw: bool = False,
    ) -> str:  # fmt: skip
        assert raw, "the recorder subscribes raw"
        self.callbacks[topic] = callback
        return topic

    def destroy_subscription(self, subscription: Any) -> None:
        self.callbacks.pop(subscription, None)

    def topic_names_and_types(self) -> dict[str, list[str]]:
        return {}


def pose_bytes(x: float, y: float, t: float) -> bytes:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from rclpy.serialization import serialize_message

    msg = PoseWithCovarianceStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), int(t % 1 * 1e9)
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.w = 1.0
    data: bytes = serialize_message(msg)
    return data


def test_the_pose_held_back_by_the_sampling_is_indexed_once_due(
    sqlite_store: EpisodicStore, places: Places, tmp_path: Path
) -> None:
    monotonic = [100.0]
    bridge = FakeBridge()
    indexer = Indexer(sqlite_store, places, clock=lambda: T)
    bags = BagRecorder(tmp_path, rotate_s=3600)
    recorder = RosRecorder(
        bridge,
        indexer,
        bags,
        "/amcl_pose",
        pose_hz=5.0,
        clock=lambda: monotonic[0],  # type: ignore[arg-type]
    )
    on_pose = bridge.callbacks["/amcl_pose"]

    on_pose(pose_bytes(8.0, -2.6, T))  # decoded: a sample was due
    monotonic[0] += 0.05
    on_pose(pose_bytes(9.0, -3.0, T + 0.05))  # held back: the robot stopped, AMCL goes quiet
    assert indexer.current_place() == "kitchen"
    recorder.catch_up()  # not due yet: still held
    indexer.flush()
    assert [(p.x, p.y) for p in sqlite_store.poses(0, T + 10)] == [(8.0, -2.6)]

    monotonic[0] += 0.2
    recorder.catch_up()
    recorder.catch_up()  # nothing left to index
    indexer.flush()
    assert [(p.x, p.y) for p in sqlite_store.poses(0, T + 10)] == [(8.0, -2.6), (9.0, -3.0)]
    assert bags.written == 2  # both went to the bag as they arrived
    bags.close()
    assert math.isclose(indexer.last_write["pose"], T + 0.05)
