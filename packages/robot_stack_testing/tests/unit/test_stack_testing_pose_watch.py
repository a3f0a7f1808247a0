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
        stamps = iter(range(1000))

        def publish_until(x: float, stamp: float) -> bool:
            """One more message (best effort may drop some) until ``stamp`` was seen."""
            latest = watch.latest()
            if latest is not None and latest.stamp >= stamp - 1e-6:
                return True
            tick = 100 + 0.05 * next(stamps)
            publisher.publish(pose(min(x, 0.1 * (tick - 100) / 0.05), tick))
            return False

        wait_until(lambda: publish_until(0.5, 100.2), 10, "driving seen", 0.005)
        assert watch.moving(window_s=0.3)
        assert watch.halted_at() is None
        wait_until(lambda: publish_until(0.5, 101.5), 20, "standing still seen", 0.005)

        assert not watch.moving(window_s=0.3)
        halted = watch.halted_at(still_s=0.5)
        assert halted is not None
        assert 100.2 <= halted <= 100.5  # where 0.5 m was first reached (samples may drop)
    finally:
        watch.close()
