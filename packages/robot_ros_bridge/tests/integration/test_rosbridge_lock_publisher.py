"""SupervisorLockPublisher over real rclpy: its value at >= 10 Hz, then silence once closed,
read through twist_mux's rules by a subscriber in another node."""

import threading
import time
import uuid
from collections.abc import Iterator

import pytest
from std_msgs.msg import Bool

from robot_ros_bridge import RosBridge
from robot_ros_bridge.dead_man_lock import TwistMuxLock
from robot_ros_bridge.lock_publisher import LOCK_QOS, SupervisorLockPublisher
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros


@pytest.fixture
def bridges() -> Iterator[tuple[RosBridge, RosBridge]]:
    with RosBridge("lock_server") as server, RosBridge("lock_mux") as mux:
        yield server, mux


class Mux:
    """The twist_mux side: a reliable subscription feeding a TwistMuxLock."""

    def __init__(self, bridge: RosBridge, topic: str) -> None:
        self.lock = TwistMuxLock(timeout_s=0.5)
        self.stamps: list[float] = []
        self._mutex = threading.Lock()
        bridge.create_subscription(Bool, topic, self._on, LOCK_QOS)

    def _on(self, msg: Bool) -> None:
        with self._mutex:
            now = time.monotonic()
            self.lock.on_message(msg.data, now)
            self.stamps.append(now)

    def locked(self) -> bool:
        with self._mutex:
            return self.lock.is_locked(time.monotonic())


def test_the_lock_follows_its_value_and_locks_when_the_publisher_falls_silent(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, mux_bridge = bridges
    topic = f"/lock_{uuid.uuid4().hex[:8]}"
    value = {"locked": False}
    mux = Mux(mux_bridge, topic)
    publisher = SupervisorLockPublisher(server, lambda: value["locked"], topic=topic, rate_hz=20)

    wait_until(lambda: not mux.locked(), 15, "the lock opened")
    value["locked"] = True
    wait_until(mux.locked, 5, "the lock locked on true")
    value["locked"] = False
    # Twice in fresh-clone CI runs (stop 33, stop 40) no sample reached the other node of this
    # process for over 10 s at load < 1: a DDS stall between two participants of one process,
    # not the publisher's logic, and on the safe side (a silent lock is locked). The deadline
    # covers such a stall; a publisher that never reopens the lock still fails here.
    wait_until(lambda: not mux.locked() and len(mux.stamps) > 25, 30, "open again, 25 messages")

    publisher.close()
    wait_until(mux.locked, 5, "silent = locked")
    publisher.close()  # idempotent


def test_a_lock_rate_below_10_hz_is_refused(bridges: tuple[RosBridge, RosBridge]) -> None:
    server, _ = bridges
    with pytest.raises(ValueError, match="10 Hz"):
        SupervisorLockPublisher(server, lambda: True, topic="/lock_slow", rate_hz=5)
