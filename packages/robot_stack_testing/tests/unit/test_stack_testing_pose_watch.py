"""AmclWatch reads /amcl_pose from ROS and dates a halt by the messages' own stamps."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped

from robot_ros_bridge import RosBridge
from robot_stack_testing import wait_until
from robot_stack_testing.pose_watch import AmclWatch

pytestmark = pytest.mark.ros


@pytest.fixture
def topic() -> str:
    return f"/amcl_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def robot() -> Iterator[RosBridge]:
    with RosBridge("fake_robot") as bridge:
        yield bridge


def pose(x: float, stamp: float) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp.sec = int(stamp)
    msg.header.stamp.nanosec = int((stamp % 1) * 1e9)
    msg.pose.pose.position.x = x
    return msg


def test_a_halt_is_the_stamp_of_the_first_message_at_the_final_position(
    robot: RosBridge, topic: str
) -> None:
    watch = AmclWatch(topic)
    try:
        publisher = robot.create_publisher(PoseWithCovarianceStamped, topic)
        wait_until(lambda: robot.node.count_subscribers(topic) >= 1, 10, "the watch subscribed")
        ticks = iter(range(1, 10_000))
        sent: list[tuple[float, float]] = []  # (stamp, x) published

        def drive_on() -> bool:
            """One more message 0.1 m further (best effort may drop some) until it moves."""
            if watch.moving(window_s=0.3):
                return True
            tick = next(ticks)
            sent.append((100 + 0.05 * tick, 0.1 * tick))
            publisher.publish(pose(sent[-1][1], sent[-1][0]))
            return False

        wait_until(drive_on, 10, "driving seen", 0.005)
        assert watch.halted_at() is None
        stopped_at, x = sent[-1]  # it stops here

        def stand() -> bool:
            if watch.halted_at(still_s=0.5) is not None:
                return True
            publisher.publish(pose(x, 100 + 0.05 * next(ticks)))
            return False

        wait_until(stand, 20, "standing still seen", 0.005)

        assert not watch.moving(window_s=0.3)
        halted = watch.halted_at(still_s=0.5)
        assert halted is not None
        assert halted == pytest.approx(stopped_at, abs=0.3)  # its first sample there, or later
    finally:
        watch.close()
