"""RclpyArm: the ArmActions port over rclpy, through the process's RosBridge (one Node, a
MultiThreadedExecutor in a daemon thread; futures handed to the event loop).

Imports rclpy and robot_manipulation_interfaces: only the composition root imports this module.
"""

from __future__ import annotations

import asyncio
import collections
import math
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any

import structlog
from action_msgs.msg import GoalInfo, GoalStatus
from builtin_interfaces.msg import Time
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from robot_manipulation_interfaces.action import Pick, Place
from robot_manipulation_interfaces.msg import DetectionRef, HeldObject

from robot_mcp_manipulation.arm.port import (
    ArmActions,
    ArmFeedback,
    ArmGoal,
    ArmOutcome,
    ArmUnavailableError,
    DetectionTarget,
    FeedbackCallback,
    Held,
    PlaceMode,
)
from robot_mcp_manipulation.arm.port import (
    GoalStatus as Status,
)
from robot_ros_bridge import RosBridge, ServiceTimeoutError, ServiceUnavailableError
from robot_ros_bridge.action_cancel import ActionCanceller

logger = structlog.get_logger(__name__)

_STATUS: dict[int, Status] = {
    GoalStatus.STATUS_SUCCEEDED: "succeeded",
    GoalStatus.STATUS_ABORTED: "aborted",
    GoalStatus.STATUS_CANCELED: "canceled",
}
HELD_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""The robot latches what it holds: a client that starts later knows at once."""


def time_of(stamp_s: float) -> Time:
    """Unix seconds (as JSON carried them) → builtin_interfaces/Time."""
    sec = math.floor(stamp_s)
    nanosec = min(round((stamp_s - sec) * 1e9), 999_999_999)
    return Time(sec=int(sec), nanosec=int(nanosec))


def seconds_of(stamp: Any) -> float:
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def held_of(msg: Any) -> Held:
    return Held(bool(msg.holding), str(msg.label), seconds_of(msg.since))


def pick_goal(target: DetectionTarget, max_age_s: float) -> Any:
    ref = DetectionRef(
        topic=target.topic, stamp=time_of(target.stamp_s), index=target.index, label=target.label
    )
    return Pick.Goal(target=ref, max_age_s=float(max_age_s))


def place_goal(mode: PlaceMode) -> Any:
    return Place.Goal(mode=Place.Goal.RELEASE if mode == "release" else Place.Goal.PLACE)


class RclpyArmGoal(ArmGoal):
    def __init__(self, bridge: RosBridge, handle: Any, on_held: Callable[[Held], None]) -> None:
        self._bridge = bridge
        self._handle = handle
        self._on_held = on_held
        self._result_future = handle.get_result_async()

    async def outcome(self) -> ArmOutcome:
        response = await self._bridge.await_future(self._result_future, None)
        result = response.result
        held = held_of(result.held)
        # The result says what is held when the goal ended; the held topic may arrive later
        # (another topic, no ordering across them), so a read right after a pick is not stale.
        self._on_held(held)
        return ArmOutcome(
            _STATUS.get(int(response.status), "unknown"),
            int(result.error_code),
            str(result.error_msg),
            held,
            str(getattr(result, "placed_label", "")),
        )

    async def cancel(self, timeout_s: float) -> bool:
        try:
            response = await self._bridge.await_future(self._handle.cancel_goal_async(), timeout_s)
        except ServiceTimeoutError:
            return False
        return len(response.goals_canceling) > 0


class RclpyArm(ArmActions):
    def __init__(
        self, bridge: RosBridge, pick_action: str, place_action: str, held_topic: str
    ) -> None:
        self._bridge = bridge
        self._names = {"pick": pick_action, "place": place_action}
        self._clients = {
            "pick": bridge.create_action_client(Pick, pick_action),
            "place": bridge.create_action_client(Place, place_action),
        }
        self._cancellers = [ActionCanceller(bridge, name) for name in (pick_action, place_action)]
        self._sent: collections.deque[bytes] = collections.deque(maxlen=64)
        self._sent_mutex = threading.Lock()
        self._held: Held | None = None
        bridge.create_subscription(HeldObject, held_topic, self._on_held, HELD_QOS)

    @property
    def action_names(self) -> tuple[str, str]:
        return self._names["pick"], self._names["place"]

    def sent(self, goal_id: bytes) -> bool:
        """Whether this client sent the goal ``goal_id`` (one of its last 64 goals)."""
        with self._sent_mutex:
            return goal_id in self._sent

    async def cancel_all(self, timeout_s: float) -> bool:
        """The action protocol's cancel-all on Pick and Place (every goal, whoever sent it);
        True when both servers answered."""
        answers = await asyncio.gather(*(c.cancel_all(timeout_s) for c in self._cancellers))
        return all(answer is not None for answer in answers)

    def cancel_all_now(self) -> None:
        """Both cancel-alls sent at once from any thread (the graph watcher's)."""
        for canceller in self._cancellers:
            canceller.cancel_all_now()

    def _on_held(self, msg: Any) -> None:  # executor thread; one reference assignment
        self._held = held_of(msg)

    def _remember_held(self, held: Held) -> None:
        self._held = held

    def held(self) -> Held | None:
        return self._held

    async def send_pick(
        self,
        target: DetectionTarget,
        max_age_s: float,
        on_feedback: FeedbackCallback,
        timeout_s: float,
    ) -> ArmGoal:
        return await self._send("pick", pick_goal(target, max_age_s), on_feedback, timeout_s)

    async def send_place(
        self, mode: PlaceMode, on_feedback: FeedbackCallback, timeout_s: float
    ) -> ArmGoal:
        return await self._send("place", place_goal(mode), on_feedback, timeout_s)

    async def _send(
        self, kind: str, goal: Any, on_feedback: FeedbackCallback, timeout_s: float
    ) -> ArmGoal:
        started = time.monotonic()
        client, name = self._clients[kind], self._names[kind]
        try:
            await self._bridge.wait_for_server(client, timeout_s)
        except ServiceUnavailableError:
            raise ArmUnavailableError(
                f"no {kind} action server on {name} within {timeout_s:g} s (is the robot's "
                "manipulation node up, in this ROS_DOMAIN_ID?)"
            ) from None
        loop = asyncio.get_running_loop()

        def feedback(msg: Any) -> None:  # executor thread
            if not loop.is_closed():
                fb = ArmFeedback(str(msg.feedback.phase), float(msg.feedback.progress))
                loop.call_soon_threadsafe(on_feedback, fb)

        goal_id = uuid.uuid4().bytes  # known before the server answers: the watcher's "ours"
        with self._sent_mutex:
            self._sent.append(goal_id)
        goal_uuid = GoalInfo().goal_id
        goal_uuid.uuid = list(goal_id)
        sent = client.send_goal_async(goal, feedback_callback=feedback, goal_uuid=goal_uuid)
        remaining = max(timeout_s - (time.monotonic() - started), timeout_s / 2)
        try:
            handle = await self._bridge.await_future(sent, remaining)
        except asyncio.CancelledError:
            sent.add_done_callback(_cancel_if_accepted)  # never leave a goal we gave up on
            raise
        except ServiceTimeoutError:
            sent.add_done_callback(_cancel_if_accepted)
            raise ArmUnavailableError(
                f"the {kind} action server on {name} did not answer within {timeout_s:g} s"
            ) from None
        if not handle.accepted:
            raise ArmUnavailableError(
                f"the {kind} action server on {name} rejected the goal (the arm is busy?)"
            )
        return RclpyArmGoal(self._bridge, handle, self._remember_held)


def _cancel_if_accepted(future: Any) -> None:
    """A goal accepted after we stopped waiting for the answer is canceled at once."""
    handle = future.result() if future.exception() is None else None
    if handle is not None and handle.accepted:
        logger.warning("arm_late_goal_canceled")
        handle.cancel_goal_async()
