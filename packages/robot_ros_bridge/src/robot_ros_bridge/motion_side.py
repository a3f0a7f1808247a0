"""MotionRosSide: a motion server's ROS side (issue 27, issue 35) — its bridge and, when it is
supervised, its dead-man lock on a topic of its own and the graph watcher that raises its alarms
(a second publisher of that lock topic, an open lock this process did not send). The domain's
adapters are built on ``side.bridge``; what else the domain watches it adds to ``side.watcher``.

Imports rclpy: only a composition root imports this module, lazily.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.graph_watch import GraphWatcher
from robot_ros_bridge.lock_publisher import SupervisorLockPublisher


@dataclass(frozen=True)
class DeadManLock:
    """The lock a supervised motion server publishes: ``locked()`` its value, ``raise_alarm``
    where the watcher's alarms go, ``shared_code`` the alarm of a second publisher on it."""

    topic: str
    rate_hz: float
    locked: Callable[[], bool]
    raise_alarm: Callable[[str, str], object]
    shared_code: str
    what: str


@dataclass
class MotionRosSide:
    bridge: RosBridge
    lock: SupervisorLockPublisher | None = None
    watcher: GraphWatcher | None = None

    def publish_lock(self) -> None:
        if self.lock is not None:
            self.lock.publish()

    def close(self) -> None:
        if self.lock is not None:
            self.lock.close()  # the lock falls silent first: twist_mux locks
        if self.watcher is not None:
            self.watcher.close()
        self.bridge.close()


def open_motion_side(node_name: str, lock: DeadManLock | None = None) -> MotionRosSide:
    """Start the bridge (node ``node_name``) and, with ``lock``, the lock and its watcher."""
    bridge = RosBridge(node_name).start()
    if lock is None:
        return MotionRosSide(bridge)
    try:
        publisher = SupervisorLockPublisher(
            bridge, lock.locked, topic=lock.topic, rate_hz=lock.rate_hz
        )
        watcher = GraphWatcher(bridge, lock.raise_alarm)
        watcher.watch_publishers(lock.topic, lock.shared_code, own=True, what=lock.what)
        watcher.watch_lock(
            lock.topic,
            lock.shared_code,
            locked=lock.locked,
            last_open_at=publisher.last_open_at,
            what=lock.what,
        )
    except BaseException:
        bridge.close()
        raise
    return MotionRosSide(bridge, publisher, watcher)
