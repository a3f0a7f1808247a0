"""SupervisorLockPublisher: a motion server's dead-man lock on the robot's twist_mux.

Publishes ``std_msgs/Bool`` (``true`` = locked) at a fixed rate from a ROS timer on the
bridge's executor thread, so the lock keeps its rate whatever the server's event loop does;
its value comes from ``locked()`` (``robot_mcp_kit.supervision.Supervision.locked``). When
the process dies the topic falls silent, which twist_mux counts as locked after its timeout.
Reliable + volatile like twist_mux's own subscription (``SystemDefaultsQoS``).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import structlog
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.dead_man_lock import LOCK_RATE_HZ, LOCK_TOPIC, MIN_LOCK_RATE_HZ

logger = structlog.get_logger(__name__)

LOCK_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


class SupervisorLockPublisher:
    def __init__(
        self,
        bridge: RosBridge,
        locked: Callable[[], bool],
        *,
        topic: str = LOCK_TOPIC,
        rate_hz: float = LOCK_RATE_HZ,
    ) -> None:
        if rate_hz < MIN_LOCK_RATE_HZ:
            raise ValueError(f"a supervisor lock is published at >= {MIN_LOCK_RATE_HZ:g} Hz")
        self.topic = topic
        self._bridge = bridge
        self._locked = locked
        self._mutex = threading.Lock()
        self._last: bool | None = None
        self._last_open_at: float | None = None
        self._shared_warned = False
        self._ticks = 0
        self._check_every = max(1, round(rate_hz))  # the graph is looked at once a second
        self._publisher: Any = bridge.create_publisher(Bool, topic, LOCK_QOS)
        self._timer: Any = bridge.node.create_timer(1.0 / rate_hz, self._tick)
        logger.info("supervisor_lock_publishing", topic=topic, rate_hz=rate_hz)

    def _tick(self) -> None:
        self.publish()

    def publish(self) -> bool:
        """Publish the current value now (the timer, and whoever must not wait for it)."""
        value = bool(self._locked())
        with self._mutex:
            if self._publisher is None:
                return value
            self._publisher.publish(Bool(data=value))
            if not value:
                self._last_open_at = time.monotonic()
            changed, self._last = value != self._last, value
            self._ticks += 1
            check = self._ticks % self._check_every == 1
        if changed:
            log = logger.warning if value else logger.info
            log("supervisor_lock_changed", topic=self.topic, locked=value)
        if check:
            self._check_shared()
        return value

    def last_open_at(self) -> float | None:
        """When this publisher last published ``false`` (open), ``time.monotonic()``."""
        with self._mutex:
            return self._last_open_at

    def _check_shared(self) -> None:
        """Another publisher on this topic would hide our silence from twist_mux: say so."""
        shared = self._bridge.publisher_count(self.topic) > 1
        if shared and not self._shared_warned:
            logger.error(
                "supervisor_lock_topic_shared",
                topic=self.topic,
                detail="another node publishes this lock topic: twist_mux keeps the last "
                "message of any publisher, so give every motion server its own lock topic",
            )
        self._shared_warned = shared

    def close(self) -> None:
        """Stop publishing (idempotent): the lock falls silent, twist_mux locks."""
        with self._mutex:
            publisher, timer = self._publisher, self._timer
            self._publisher = self._timer = None
        if publisher is None or self._bridge.closed:
            return
        self._bridge.node.destroy_timer(timer)
        self._bridge.node.destroy_publisher(publisher)
