"""The robot's twist_mux, as far as its supervisor locks go: robot-sim's drive obeys them.

A robot runs twist_mux in front of its base controller with a lock entry per motion server
(``deploy/twist_mux/supervisor_lock.yaml``: ``std_msgs/Bool``, priority 255, a timeout). While a
lock is locked — ``true``, or its publisher silent longer than the timeout, or never heard
(``robot_ros_bridge.dead_man_lock``, twist_mux 4.3.0's rules) — twist_mux forwards no velocity
command and the base controller's command timeout stops the wheels. Here that is: the drive
halts (``DriveSim.halt``) within one check period of the lock engaging, and stays halted.

Nav2 does not learn of a twist_mux lock: its controller keeps computing commands, the robot
does not move, its progress checker gives up after ``movement_time_allowance`` (10 s by default)
and the NavigateToPose goal ends ABORTED with the controller's FAILED_TO_MAKE_PROGRESS (105).
robot-sim reports the same code at once (it knows why the base stopped); a goal sent while
locked is accepted and aborted the same way, as Nav2 would.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

import structlog
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from std_msgs.msg import Bool

from robot_ros_bridge.dead_man_lock import LOCK_PRIORITY, TwistMuxLock
from robot_ros_bridge.lock_publisher import LOCK_QOS
from robot_sim.drive import DriveSim

logger = structlog.get_logger(__name__)

CHECK_HZ = 50.0
"""How often a silent lock is looked for (a ``true`` halts at once, on arrival)."""


class SupervisorLockGate:
    def __init__(
        self,
        node: Node,
        drive: DriveSim,
        topics: Sequence[str],
        timeout_s: float,
        clock: Callable[[], float],
        on_halt: Callable[[], None] = lambda: None,
    ) -> None:
        self._drive = drive
        self._clock = clock
        self._on_halt = on_halt
        self._mutex = threading.Lock()
        self._locks = {topic: TwistMuxLock(timeout_s, LOCK_PRIORITY) for topic in topics}
        self._was_locked: bool | None = None
        group = MutuallyExclusiveCallbackGroup()
        for topic in topics:
            node.create_subscription(
                Bool, topic, self._subscriber(topic), LOCK_QOS, callback_group=group
            )
        node.create_timer(1.0 / CHECK_HZ, self.enforce, callback_group=group)
        logger.info("supervisor_lock_honoured", topics=list(topics), timeout_s=timeout_s)

    def _subscriber(self, topic: str) -> Callable[[Any], None]:
        def on_message(msg: Any) -> None:
            with self._mutex:
                self._locks[topic].on_message(bool(msg.data), self._clock())
            if msg.data:
                self.enforce()

        return on_message

    def held_by(self) -> list[str]:
        """The lock topics that hold the base now (empty: velocity commands pass)."""
        now = self._clock()
        with self._mutex:
            return [topic for topic, lock in self._locks.items() if lock.is_locked(now)]

    def locked(self) -> bool:
        return bool(self.held_by())

    def enforce(self) -> None:
        """Halt the drive while any lock is locked; log each change of the locks."""
        held = self.held_by()
        now = self._clock()
        if bool(held) != self._was_locked:
            self._was_locked = bool(held)
            if held:
                logger.warning("supervisor_lock_engaged", topics=held)
            else:
                logger.info("supervisor_lock_released")
        if held and self._drive.state(now).driving:
            state = self._drive.halt(now)
            logger.warning(
                "base_held_by_supervisor_lock",
                topics=held,
                x=round(state.pose.x, 2),
                y=round(state.pose.y, 2),
            )
            self._on_halt()
