"""The robot's twist_mux, as far as its supervisor locks go: robot-sim's drive obeys them.

A robot runs twist_mux in front of its base controller with a lock entry per motion server
(``deploy/twist_mux/supervisor_lock.yaml``: ``std_msgs/Bool``, priority 255, a timeout). While a
lock is locked — ``true``, or its publisher silent longer than the timeout, or never heard
(``robot_ros_bridge.dead_man_lock``, twist_mux 4.3.0's rules) — twist_mux forwards no velocity
command and the base controller's command timeout stops the wheels. Here that is: the drive
halts (``DriveSim.halt``) within one check period of the lock engaging, and stays halted.

The halt is dated like a separate twist_mux would date it, not by when this process gets round to
it: the drive stops where it was when the lock engaged (the first ``true``, or the silent lock's
timeout running out), never earlier than a pose already published as open — so a robot-sim
starved of CPU under load does not simulate wheels that kept turning while twist_mux held them.
The pose timer enforces the lock before each ``/amcl_pose``.

Nav2 does not learn of a twist_mux lock: its controller keeps computing commands, the robot does
not move, and the NavigateToPose goal stays active — it drives on if the lock opens again, and
ends ABORTED with the controller's FAILED_TO_MAKE_PROGRESS (105) once the progress checker's
``movement_time_allowance`` (10 s by default) ran out. robot-sim does the same
(``nav2_server``, ``SIM_PROGRESS_TIMEOUT_S``); a goal sent while locked waits the same way. The
motion servers cancel every goal of the action (the protocol's cancel-all, whoever sent it) when
supervision ends and again before their lock opens after a clear (issue 35), so a goal resumes
only after a brief lock its server never saw end (a starved host), never after a lapse or a
latch. rclpy's ActionServer (``nav2_server``, ``manipulation_server``) honours the cancel-all.

The arm has its own locks (issue 39): a robot's arm controller (its safety controller or its
ros2_control command gate) sits behind the manipulation server's lock
(``/robot/supervisor_lock/manipulation``), never behind twist_mux — a dead arm server must not
hold the wheels of a robot that can still drive, and a dead navigation server must not freeze an
arm mid-grasp that its own supervised server still runs. :class:`ArmLockGate` is that gate: the
same rules (never heard, ``true`` or silent longer than the timeout = locked); while locked the
gripper's pick or place stands still (``manipulation_server``) and gives up ``ARM_NOT_READY``
after ``SIM_PROGRESS_TIMEOUT_S``.
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


class DeadManLocks:
    """One twist_mux-rules lock per topic (``robot_ros_bridge.dead_man_lock``), subscribed
    reliable like twist_mux; ``on_true`` runs when a ``true`` arrives (a halt at once)."""

    def __init__(
        self,
        node: Node,
        topics: Sequence[str],
        timeout_s: float,
        clock: Callable[[], float],
        group: MutuallyExclusiveCallbackGroup,
        on_true: Callable[[], None] = lambda: None,
    ) -> None:
        self._clock = clock
        self._on_true = on_true
        self._mutex = threading.Lock()
        self._locks = {topic: TwistMuxLock(timeout_s, LOCK_PRIORITY) for topic in topics}
        self.started = clock()
        for topic in topics:
            node.create_subscription(
                Bool, topic, self._subscriber(topic), LOCK_QOS, callback_group=group
            )

    def _subscriber(self, topic: str) -> Callable[[Any], None]:
        def on_message(msg: Any) -> None:
            with self._mutex:
                lock = self._locks[topic]
                ran_out = lock.stamp is not None and lock.has_expired(self._clock())
            if ran_out:
                # silent past its timeout before this message came (robot-sim starved, the
                # message queued): twist_mux held the base meanwhile, so the halt is dated
                # before the message opens the lock again
                self._on_true()
            with self._mutex:
                lock.on_message(bool(msg.data), self._clock())
            if msg.data:
                self._on_true()

        return on_message

    def held_by(self, now: float | None = None) -> list[str]:
        """The lock topics that are locked now (empty: the part may move)."""
        now = self._clock() if now is None else now
        with self._mutex:
            return [topic for topic, lock in self._locks.items() if lock.is_locked(now)]

    def engaged_at(self, now: float) -> float:
        """When the locks that hold now engaged (twist_mux's view: a ``true`` when it came,
        a silent lock when its timeout ran out, one never heard since we started)."""
        with self._mutex:
            times = [
                lock.stamp
                if lock.data and lock.stamp is not None
                else (lock.stamp + lock.timeout_s if lock.stamp is not None else self.started)
                for lock in self._locks.values()
                if lock.is_locked(now)
            ]
        return min(times, default=now)


class SupervisorLockGate:
    """The base's locks (twist_mux in front of the base controller): the drive halts."""

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
        self._enforcing = threading.Lock()  # the gate's timer and the pose timer
        group = MutuallyExclusiveCallbackGroup()
        self._locks = DeadManLocks(node, topics, timeout_s, clock, group, self.enforce)
        self._was_locked: bool | None = None
        self._last_open = self._locks.started  # the last moment the locks were seen open
        node.create_timer(1.0 / CHECK_HZ, self.enforce, callback_group=group)
        logger.info(
            "supervisor_lock_honoured", part="base", topics=list(topics), timeout_s=timeout_s
        )

    def held_by(self) -> list[str]:
        """The lock topics that hold the base now (empty: velocity commands pass)."""
        return self._locks.held_by()

    def locked(self) -> bool:
        return bool(self.held_by())

    def enforce(self) -> None:
        """Halt the drive while any lock is locked; log each change of the locks."""
        with self._enforcing:
            now = self._clock()
            held = self._locks.held_by(now)
            if bool(held) != self._was_locked:
                self._was_locked = bool(held)
                if held:
                    logger.warning("supervisor_lock_engaged", part="base", topics=held)
                else:
                    logger.info("supervisor_lock_released", part="base")
            if not held:
                self._last_open = now
                return
            at = min(now, max(self._locks.engaged_at(now), self._last_open))
            if not self._drive.state(at).driving:  # (advancing the drive no further than at)
                return
            state = self._drive.halt(at)
            logger.warning(
                "base_held_by_supervisor_lock",
                topics=held,
                late_ms=round((now - at) * 1000, 1),
                x=round(state.pose.x, 2),
                y=round(state.pose.y, 2),
            )
        self._on_halt()


class ArmLockGate:
    """The arm's locks (the arm controller's command gate): ``locked()`` holds the gripper's
    running pick or place where it is (``ManipulationServer.held``); each change is logged."""

    def __init__(
        self,
        node: Node,
        topics: Sequence[str],
        timeout_s: float,
        clock: Callable[[], float],
    ) -> None:
        self._mutex = threading.Lock()
        group = MutuallyExclusiveCallbackGroup()
        self._locks = DeadManLocks(node, topics, timeout_s, clock, group, self.check)
        self._was_locked: bool | None = None
        node.create_timer(1.0 / CHECK_HZ, self.check, callback_group=group)
        logger.info(
            "supervisor_lock_honoured", part="arm", topics=list(topics), timeout_s=timeout_s
        )

    def held_by(self) -> list[str]:
        """The lock topics that hold the arm now (empty: the arm may move)."""
        return self._locks.held_by()

    def locked(self) -> bool:
        return bool(self.held_by())

    def check(self) -> None:
        """Log each change of the arm's locks (the gripper reads ``locked`` itself)."""
        held = self.held_by()
        with self._mutex:
            if bool(held) == self._was_locked:
                return
            self._was_locked = bool(held)
        if held:
            logger.warning("supervisor_lock_engaged", part="arm", topics=held)
        else:
            logger.info("supervisor_lock_released", part="arm")
