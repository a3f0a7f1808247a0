"""RclpyNav2Action: the Nav2Action port over rclpy, through the process's RosBridge (one Node,
a MultiThreadedExecutor in a daemon thread; futures handed to the event loop).

Imports rclpy, nav2_msgs and geometry_msgs: only the composition root imports this module,
and only with ``NAV_MOTION=nav2``.
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
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from robot_mcp_navigation.motion.base import Pose
from robot_mcp_navigation.motion.nav2.port import (
    GoalStatus as Status,
)
from robot_mcp_navigation.motion.nav2.port import (
    Nav2Action,
    Nav2Feedback,
    Nav2Goal,
    Nav2Outcome,
    Nav2UnavailableError,
    PoseSample,
)
from robot_mcp_navigation.motion.nav2.pose_watch import PoseContinuity, Relocation
from robot_ros_bridge import RosBridge, ServiceTimeoutError, ServiceUnavailableError
from robot_ros_bridge.action_cancel import ActionCanceller

logger = structlog.get_logger(__name__)

_STATUS: dict[int, Status] = {
    GoalStatus.STATUS_SUCCEEDED: "succeeded",
    GoalStatus.STATUS_ABORTED: "aborted",
    GoalStatus.STATUS_CANCELED: "canceled",
}

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


def goal_uuid_msg(goal_id: bytes) -> Any:
    """A unique_identifier_msgs/UUID carrying ``goal_id`` (16 bytes)."""
    msg = GoalInfo().goal_id
    msg.uuid = list(goal_id)
    return msg


def feedback_of(msg: Any) -> Nav2Feedback:
    return Nav2Feedback(
        pose=pose_of(msg.current_pose.pose),
        distance_remaining_m=float(msg.distance_remaining),
        eta_s=seconds_of(msg.estimated_time_remaining),
        navigation_time_s=seconds_of(msg.navigation_time),
        recoveries=int(msg.number_of_recoveries),
    )


class RclpyGoal(Nav2Goal):
    def __init__(self, bridge: RosBridge, handle: Any, result_future: Any) -> None:
        self._bridge = bridge
        self._handle = handle
        self._result_future = result_future

    async def outcome(self) -> Nav2Outcome:
        response = await self._bridge.await_future(self._result_future, None)
        status = _STATUS.get(int(response.status), "unknown")
        result = response.result
        # Humble's NavigateToPose result is empty (error_code came with Iron): "no code".
        code = int(getattr(result, "error_code", 0))
        return Nav2Outcome(status, code, str(getattr(result, "error_msg", "")))

    async def cancel(self, timeout_s: float) -> bool:
        try:
            response = await self._bridge.await_future(self._handle.cancel_goal_async(), timeout_s)
        except ServiceTimeoutError:
            return False
        return len(response.goals_canceling) > 0


class RclpyNav2Action(Nav2Action):
    def __init__(self, bridge: RosBridge, action_name: str, pose_topic: str) -> None:
        self._bridge = bridge
        self._action_name = action_name
        self._client = bridge.create_action_client(NavigateToPose, action_name)
        self._canceller = ActionCanceller(bridge, action_name)
        self._sent: collections.deque[bytes] = collections.deque(maxlen=64)
        self._sent_mutex = threading.Lock()
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
        return await self._canceller.cancel_all(timeout_s)

    def cancel_all_now(self) -> bool:
        """The cancel-all sent at once from any thread (the graph watcher's)."""
        return self._canceller.cancel_all_now()

    def sent(self, goal_id: bytes) -> bool:
        """Whether this client sent the goal ``goal_id`` (one of its last 64 goals)."""
        with self._sent_mutex:
            return goal_id in self._sent

    def last_relocation(self) -> Relocation | None:
        return self._continuity.relocation

    async def send_goal(
        self,
        pose: Pose,
        frame: str,
        on_feedback: Callable[[Nav2Feedback], None],
        timeout_s: float,
    ) -> Nav2Goal:
        started = time.monotonic()
        try:
            await self._bridge.wait_for_server(self._client, timeout_s)
        except ServiceUnavailableError:
            raise Nav2UnavailableError(
                f"no Nav2 NavigateToPose action server on {self._action_name} within "
                f"{timeout_s:g} s (is Nav2 up, in this ROS_DOMAIN_ID?)"
            ) from None
        loop = asyncio.get_running_loop()

        def feedback(msg: Any) -> None:  # executor thread
            if not loop.is_closed():
                loop.call_soon_threadsafe(on_feedback, feedback_of(msg.feedback))

        goal_id = uuid.uuid4().bytes  # known before the server answers: the watcher's "ours"
        with self._sent_mutex:
            self._sent.append(goal_id)
        sent = self._client.send_goal_async(
            goal_message(pose, frame),
            feedback_callback=feedback,
            goal_uuid=goal_uuid_msg(goal_id),
        )
        remaining = max(timeout_s - (time.monotonic() - started), timeout_s / 2)
        try:
            handle = await self._bridge.await_future(sent, remaining)
        except asyncio.CancelledError:
            sent.add_done_callback(_cancel_if_accepted)  # never leave a goal we gave up on
            raise
        except ServiceTimeoutError:
            sent.add_done_callback(_cancel_if_accepted)
            raise Nav2UnavailableError(
                f"the Nav2 action server on {self._action_name} did not answer the goal "
                f"within {timeout_s:g} s"
            ) from None
        if not handle.accepted:
            raise Nav2UnavailableError(
                f"the Nav2 action server on {self._action_name} rejected the goal "
                "(is Nav2 active, is the pose inside its map?)"
            )
        return RclpyGoal(self._bridge, handle, handle.get_result_async())


def _cancel_if_accepted(future: Any) -> None:
    """A goal accepted after we stopped waiting for the answer is canceled at once."""
    handle = future.result() if future.exception() is None else None
    if handle is not None and handle.accepted:
        logger.warning("nav2_late_goal_canceled")
        handle.cancel_goal_async()
