"""ActionCanceller: cancel every goal an action server runs or holds, whoever sent it.

The ROS 2 action protocol's cancel-all (``action_msgs/srv/CancelGoal`` on
``<action>/_action/cancel_goal`` with a **zero goal id and a zero stamp**): the server cancels
all its goals, not only the caller's. Nav2's bt_navigator, rclpy's ``ActionServer`` (robot-sim's
NavigateToPose, Pick and Place) and rclcpp_action servers all implement it (the goal selection is
``rcl_action_process_cancel_request``, shared by every client library since Foxy).

A motion server uses it when its software stop latches, lapses or alarms — a latch reaches
everything below it, goals sent straight to the base included — and again right before its
dead-man lock opens after a clear, so a goal held below the lock never runs on "Clear stop".
"""

from __future__ import annotations

import threading
from typing import Any

import structlog
from action_msgs.srv import CancelGoal

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.errors import ServiceTimeoutError, ServiceUnavailableError

logger = structlog.get_logger(__name__)


def cancel_all_request() -> Any:
    """A CancelGoal request with a zero goal id and a zero stamp: every goal of the server."""
    return CancelGoal.Request()  # the message's defaults are zeros


class ActionCanceller:
    def __init__(self, bridge: RosBridge, action_name: str) -> None:
        self.action_name = action_name
        self.service = f"{action_name.rstrip('/')}/_action/cancel_goal"
        self._bridge = bridge
        self._client = bridge.create_client(CancelGoal, self.service)
        self._mutex = threading.Lock()

    async def cancel_all(self, timeout_s: float) -> int | None:
        """Cancel every goal; how many the server is canceling, None when no server answered
        within ``timeout_s`` (none up: nothing of it runs)."""
        try:
            response = await self._bridge.call_service(
                self._client, cancel_all_request(), timeout_s, wait_for_service_s=timeout_s
            )
        except (ServiceUnavailableError, ServiceTimeoutError):
            return None
        canceling = len(response.goals_canceling)
        if canceling:
            logger.warning("action_goals_canceled", action=self.action_name, canceling=canceling)
        return canceling

    def ready(self) -> bool:
        """The action server's cancel service is matched."""
        return bool(self._client.service_is_ready())

    def cancel_all_now(self) -> bool:
        """Send the cancel-all at once, from any thread, without waiting for the answer (a
        goal seen on the status topic while the stop holds). False when no server is ready."""
        with self._mutex:
            if not self._client.service_is_ready():
                return False
            future = self._client.call_async(cancel_all_request())
        future.add_done_callback(_retrieved)  # an answer nobody awaits; its error is logged
        logger.warning("action_cancel_all_sent", action=self.action_name)
        return True


def _retrieved(future: Any) -> None:
    if future.exception() is not None:
        logger.info("action_cancel_all_unanswered", error=str(future.exception()))
