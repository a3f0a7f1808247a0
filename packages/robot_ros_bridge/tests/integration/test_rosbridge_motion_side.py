"""A motion server's ROS side over real rclpy: unsupervised it is the bridge alone; supervised its
dead-man lock reaches a subscriber, its watcher guards the lock topic and the goals it is told
to, an error while the adapters are built closes it, and closing silences the lock first."""

import threading
import uuid
from dataclasses import dataclass, field

import pytest
from std_msgs.msg import Bool

from robot_ros_bridge import RosBridge
from robot_ros_bridge.lock_publisher import LOCK_QOS
from robot_ros_bridge.motion_side import DeadManLock, open_motion_side
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros


@dataclass
class FakeSupervision:
    is_locked: bool = True
    refused: bool = True
    alarms: list[tuple[str, str]] = field(default_factory=list)

    def locked(self) -> bool:
        return self.is_locked

    def raise_alarm(self, code: str, detail: str) -> bool:
        self.alarms.append((code, detail))
        return True

    def refusal(self) -> object | None:
        return "stopped" if self.refused else None


@dataclass(frozen=True)
class Settings:
    lock_topic: str
    lock_hz: float = 20.0
    allowed_goal_clients: tuple[str, ...] = ("waypoint_follower",)


def test_an_unsupervised_side_is_its_bridge_alone() -> None:
    side = open_motion_side(f"motion_side_{uuid.uuid4().hex[:6]}")
    side.watch_goals("/navigate_to_pose", lambda goal_id: True, lambda: None, "drive")
    side.publish_lock()  # nothing to publish: no lock
    assert (side.lock, side.watcher) == (None, None)
    side.close()
    assert side.bridge.closed


def test_a_supervised_side_publishes_its_lock_and_watches_what_it_is_told() -> None:
    topic = f"/robot/supervisor_lock_{uuid.uuid4().hex[:8]}"
    supervision = FakeSupervision()
    spec = DeadManLock.of(supervision, Settings(topic), ("LOCK_SHARED", "FOREIGN_GOAL"), "lock")
    assert spec.refused()
    assert spec.allowed_clients == ("waypoint_follower",)
    heard: list[bool] = []
    mutex = threading.Lock()

    def on_lock(msg: Bool) -> None:
        with mutex:
            heard.append(bool(msg.data))

    with RosBridge("motion_side_mux") as mux:
        mux.create_subscription(Bool, topic, on_lock, LOCK_QOS)
        side = open_motion_side(f"motion_side_{uuid.uuid4().hex[:6]}", spec)
        try:
            assert side.watcher is not None
            side.watch_goals("/navigate_to_pose", lambda goal_id: True, lambda: None, "drive")
            assert [rule.code for rule in side.watcher._goals] == ["FOREIGN_GOAL"]
            side.publish_lock()
            wait_until(lambda: bool(heard), 10.0, "the lock reaches the subscriber")
            with mutex:
                assert heard[0] is True
        finally:
            side.close()
    assert side.bridge.closed


def test_an_error_while_the_adapters_are_built_closes_the_side() -> None:
    spec = DeadManLock.of(
        FakeSupervision(), Settings(f"/lock_{uuid.uuid4().hex[:8]}"), ("S", "F"), "lock"
    )
    side = open_motion_side(f"motion_side_{uuid.uuid4().hex[:6]}", spec)
    with pytest.raises(RuntimeError, match="no such action type"), side.closed_on_error():
        raise RuntimeError("no such action type")
    assert side.bridge.closed
