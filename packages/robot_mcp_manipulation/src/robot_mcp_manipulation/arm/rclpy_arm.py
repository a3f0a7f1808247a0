"""RclpyArm: the ArmActions port over rclpy, through the process's RosBridge (one Node, a
MultiThreadedExecutor in a daemon thread; futures handed to the event loop).

Imports rclpy and robot_manipulation_interfaces: only the composition root imports this module.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from typing import Any

import structlog
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
from robot_ros_bridge import RosBridge
from robot_ros_bridge.action_goal import (
    ActionGoal,
    ActionGoals,
    ActionUnavailableError,
    Unavailable,
)

logger = structlog.get_logger(__name__)

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
    def __init__(self, goal: ActionGoal, on_held: Callable[[Held], None]) -> None:
        self._goal = goal
        self._on_held = on_held

    async def outcome(self) -> ArmOutcome:
        ended = await self._goal.result()
        result = ended.result
        if result is None:  # the server was lost before it answered
            return ArmOutcome(ended.status, error_msg=ended.error)
        held = held_of(result.held)
        # The result says what is held when the goal ended; the held topic may arrive later
        # (another topic, no ordering across them), so a read right after a pick is not stale.
        self._on_held(held)
        return ArmOutcome(
            ended.status,
            int(result.error_code),
            str(result.error_msg),
            held,
            str(getattr(result, "placed_label", "")),
        )

    async def cancel(self, timeout_s: float) -> bool:
        return await self._goal.cancel(timeout_s)


_UNAVAILABLE: dict[Unavailable, str] = {
    "absent": "no {kind} action server on {name} within {timeout:g} s (is the robot's "
    "manipulation node up, in this ROS_DOMAIN_ID?)",
    "silent": "the {kind} action server on {name} did not answer within {timeout:g} s",
    "rejected": "the {kind} action server on {name} rejected the goal (the arm is busy?)",
}


class RclpyArm(ArmActions):
    def __init__(
        self, bridge: RosBridge, pick_action: str, place_action: str, held_topic: str
    ) -> None:
        self._goals = {
            "pick": ActionGoals(bridge, Pick, pick_action),
            "place": ActionGoals(bridge, Place, place_action),
        }
        self._held: Held | None = None
        bridge.create_subscription(HeldObject, held_topic, self._on_held, HELD_QOS)

    @property
    def action_names(self) -> tuple[str, str]:
        return self._goals["pick"].name, self._goals["place"].name

    def sent(self, goal_id: bytes) -> bool:
        """Whether this client sent the goal ``goal_id`` (one of its last 64 goals per action)."""
        return any(goals.sent(goal_id) for goals in self._goals.values())

    async def cancel_all(self, timeout_s: float) -> bool:
        """The action protocol's cancel-all on Pick and Place (every goal, whoever sent it);
        True when both servers answered."""
        answers = await asyncio.gather(*(g.cancel_all(timeout_s) for g in self._goals.values()))
        return all(answer is not None for answer in answers)

    def cancel_all_now(self) -> None:
        """Both cancel-alls sent at once from any thread (the graph watcher's)."""
        for goals in self._goals.values():
            goals.cancel_all_now()

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
        goals = self._goals[kind]

        def feedback(msg: Any) -> None:
            on_feedback(ArmFeedback(str(msg.phase), float(msg.progress)))

        try:
            sent = await goals.send(goal, feedback, timeout_s)
        except ActionUnavailableError as exc:
            words = _UNAVAILABLE[exc.reason].format(kind=kind, name=goals.name, timeout=timeout_s)
            raise ArmUnavailableError(words) from None
        return RclpyArmGoal(sent, self._remember_held)
