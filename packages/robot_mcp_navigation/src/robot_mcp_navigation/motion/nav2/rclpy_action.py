"""RclpyNav2Action: the Nav2Action port over rclpy, through the process's RosBridge (one Node,
a MultiThreadedExecutor in a daemon thread; futures handed to the event loop).

Imports rclpy, nav2_msgs and geometry_msgs: only the composition root imports this module,
and only with ``NAV_MOTION=nav2``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import structlog
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from robot_mcp_navigation.motion.base import Pose
from robot_mcp_navigation.motion.nav2.port import (
    Nav2Action,
    Nav2Feedback,
    Nav2Goal,
    Nav2Outcome,
    Nav2UnavailableError,
    PoseSample,
)
from robot_mcp_navigation.motion.nav2.pose_watch import PoseContinuity, Relocation
from robot_ros_bridge import RosBridge
from robot_ros_bridge.action_goal import (
    ActionGoal,
    ActionGoals,
    ActionUnavailableError,
    Unavailable,
)

logger = structlog.get_logger(__name__)

# AMCL latches its pose (reliable, transient local, depth 1): a late subscriber gets the last
# one. A transient-local reader cannot match a volatile writer, so a second, best-effort
# volatile reader takes poses from any other publisher (robot_sim, a localisation bridge).
POSE_QOS = (
    QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    ),
    QoSProfile(
        depth=1, reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE
    ),
)


def yaw_of(orientation: Any) -> float:
    q = orientation
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_of(msg_pose: Any) -> Pose:
    """A geometry_msgs/Pose as a planar Pose (x, y, yaw)."""
    return Pose(msg_pose.position.x, msg_pose.position.y, yaw_of(msg_pose.orientation))


def seconds_of(duration: Any) -> float:
    return float(duration.sec) + float(duration.nanosec) * 1e-9


def goal_message(pose: Pose, frame: str) -> Any:
    """A NavigateToPose goal for ``pose`` in ``frame``; stamp zero = the latest transform."""
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = frame
    goal.pose.pose.position.x = float(pose.x)
    goal.pose.pose.position.y = float(pose.y)
    goal.pose.pose.orientation.z = math.sin(pose.theta / 2.0)
    goal.pose.pose.orientation.w = math.cos(pose.theta / 2.0)
    return goal


def feedback_of(msg: Any) -> Nav2Feedback:
    return Nav2Feedback(
        pose=pose_of(msg.current_pose.pose),
        distance_remaining_m=float(msg.distance_remaining),
        eta_s=seconds_of(msg.estimated_time_remaining),
        navigation_time_s=seconds_of(msg.navigation_time),
        recoveries=int(msg.number_of_recoveries),
    )


class RclpyGoal(Nav2Goal):
    def __init__(self, goal: ActionGoal) -> None:
        self._goal = goal

    async def outcome(self) -> Nav2Outcome:
        ended = await self._goal.result()
        result = ended.result
        # Humble's NavigateToPose result is empty (error_code came with Iron): "no code".
        code = int(getattr(result, "error_code", 0))
        said = str(getattr(result, "error_msg", "")) if result is not None else ended.error
        return Nav2Outcome(ended.status, code, said)

    async def cancel(self, timeout_s: float) -> bool:
        return await self._goal.cancel(timeout_s)


_UNAVAILABLE: dict[Unavailable, str] = {
    "absent": "no Nav2 NavigateToPose action server on {name} within {timeout:g} s (is Nav2 up, "
    "in this ROS_DOMAIN_ID?)",
    "silent": "the Nav2 action server on {name} did not answer the goal within {timeout:g} s",
    "rejected": "the Nav2 action server on {name} rejected the goal (is Nav2 active, is the pose "
    "inside its map?)",
}


class RclpyNav2Action(Nav2Action):
    def __init__(self, bridge: RosBridge, action_name: str, pose_topic: str) -> None:
        self._goals = ActionGoals(bridge, NavigateToPose, action_name)
        self._pose: PoseSample | None = None
        self._continuity = PoseContinuity()
        for qos in POSE_QOS:
            bridge.create_subscription(PoseWithCovarianceStamped, pose_topic, self._on_pose, qos)

    def _on_pose(self, msg: Any) -> None:  # executor thread; one reference assignment
        sample = PoseSample(pose_of(msg.pose.pose), time.monotonic())
        self._pose = sample
        relocation = self._continuity.observe(sample.pose, sample.received_at)
        if relocation is not None:
            logger.warning(
                "pose_relocated",
                distance_m=round(relocation.distance_m, 2),
                silent_s=round(relocation.silent_s, 1),
                to=relocation.after.as_dict(),
            )

    def latest_pose(self) -> PoseSample | None:
        return self._pose

    async def cancel_all(self, timeout_s: float) -> int | None:
        return await self._goals.cancel_all(timeout_s)

    def cancel_all_now(self) -> bool:
        """The cancel-all sent at once from any thread (the graph watcher's)."""
        return self._goals.cancel_all_now()

    def sent(self, goal_id: bytes) -> bool:
        """Whether this client sent the goal ``goal_id`` (one of its last 64 goals)."""
        return self._goals.sent(goal_id)

    def last_relocation(self) -> Relocation | None:
        return self._continuity.relocation

    async def send_goal(
        self,
        pose: Pose,
        frame: str,
        on_feedback: Callable[[Nav2Feedback], None],
        timeout_s: float,
    ) -> Nav2Goal:
        try:
            goal = await self._goals.send(
                goal_message(pose, frame), lambda msg: on_feedback(feedback_of(msg)), timeout_s
            )
        except ActionUnavailableError as exc:
            words = _UNAVAILABLE[exc.reason].format(name=self._goals.name, timeout=timeout_s)
            raise Nav2UnavailableError(words) from None
        return RclpyGoal(goal)
