"""ActionGoals: one ROS 2 action's client as a motion server drives it, on the asyncio side.

What every motion server's rclpy adapter did for itself (navigation's NavigateToPose, the arm's
Pick and Place), said once:

- ``send``: wait (bounded) for the server, send the goal under an id known before the server
  answers (the graph watcher's "ours", :meth:`ActionGoals.sent`), hand each feedback message
  to the event loop (``call_soon_threadsafe``) and return once the server accepted the goal.
  An absent server, one that does not answer in time or that rejects the goal raises
  :class:`ActionUnavailableError` with its ``reason``; a goal accepted after we stopped
  waiting is canceled at once, never left running.
- :class:`ActionGoal`: the accepted goal's ``result()`` (status → ``succeeded`` / ``aborted`` /
  ``canceled``; a result lost before the server answered — its future failed — is
  ``unknown`` with the error's words) and ``cancel()``. A server that falls silent without
  failing the future is the caller's to notice (navigation's lost base: no feedback for
  ``NAV2_FEEDBACK_TIMEOUT_S``); the caller bounds ``result()`` with its own deadline.
- ``cancel_all`` / ``cancel_all_now``: the action protocol's cancel-all (``action_cancel``).

Imports rclpy's messages: only ROS adapter modules import this one.
"""

from __future__ import annotations

import asyncio
import collections
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import structlog
from action_msgs.msg import GoalInfo
from action_msgs.msg import GoalStatus as GoalStatusMsg

from robot_ros_bridge.action_cancel import ActionCanceller
from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.errors import RosBridgeError, ServiceTimeoutError, ServiceUnavailableError

logger = structlog.get_logger(__name__)

GoalStatus = Literal["succeeded", "aborted", "canceled", "unknown"]
Unavailable = Literal["absent", "silent", "rejected"]

STATUS: dict[int, GoalStatus] = {
    GoalStatusMsg.STATUS_SUCCEEDED: "succeeded",
    GoalStatusMsg.STATUS_ABORTED: "aborted",
    GoalStatusMsg.STATUS_CANCELED: "canceled",
}
SENT_REMEMBERED = 64
"""How many of its latest goal ids a client remembers as its own."""


class ActionUnavailableError(RosBridgeError):
    """The goal is not running: no server within the timeout (``absent``), no answer to the
    goal in time (``silent``), or the server rejected it (``rejected``)."""

    code = "action_unavailable"

    def __init__(self, reason: Unavailable, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


@dataclass(frozen=True)
class ActionResult:
    """How the server ended a goal: the mapped status and its Result message (None when the
    server was lost before it answered; ``error`` then says why)."""

    status: GoalStatus
    result: Any = None
    error: str = ""


class ActionGoal:
    """One goal the action server accepted (``goal_id``: its 16-byte id)."""

    def __init__(self, bridge: RosBridge, handle: Any, goal_id: bytes = b"") -> None:
        self.goal_id = goal_id
        self._bridge = bridge
        self._handle = handle
        self._result_future = handle.get_result_async()

    async def result(self) -> ActionResult:
        """Wait for the server's terminal status (no deadline: the caller sets one)."""
        try:
            response = await self._bridge.await_future(self._result_future, None)
        except Exception as exc:  # the result never came (the server or our side was lost)
            return ActionResult("unknown", error=str(exc) or type(exc).__name__)
        return ActionResult(STATUS.get(int(response.status), "unknown"), response.result)

    async def cancel(self, timeout_s: float) -> bool:
        """Ask the server to cancel; True when it accepted the request within ``timeout_s``."""
        try:
            response = await self._bridge.await_future(self._handle.cancel_goal_async(), timeout_s)
        except ServiceTimeoutError:
            return False
        return len(response.goals_canceling) > 0


class ActionGoals:
    """The client of one action (``action_type`` on ``action_name``) and its cancel-all."""

    def __init__(self, bridge: RosBridge, action_type: Any, action_name: str) -> None:
        self.name = action_name
        self._bridge = bridge
        self._client = bridge.create_action_client(action_type, action_name)
        self._canceller = ActionCanceller(bridge, action_name)
        self._sent: collections.deque[bytes] = collections.deque(maxlen=SENT_REMEMBERED)
        self._sent_mutex = threading.Lock()

    def sent(self, goal_id: bytes) -> bool:
        """Whether this client sent the goal ``goal_id`` (one of its latest goals)."""
        with self._sent_mutex:
            return goal_id in self._sent

    async def cancel_all(self, timeout_s: float) -> int | None:
        """Cancel every goal of the server (whoever sent it); how many it is canceling, None
        when no server answered within ``timeout_s``."""
        return await self._canceller.cancel_all(timeout_s)

    def cancel_all_now(self) -> bool:
        """The cancel-all sent at once from any thread (the graph watcher's)."""
        return self._canceller.cancel_all_now()

    async def send(
        self, goal: Any, on_feedback: Callable[[Any], None], timeout_s: float
    ) -> ActionGoal:
        """Send ``goal``; return once the server accepted it. ``on_feedback`` gets each
        feedback message's ``feedback`` on the event loop. Raises ActionUnavailableError."""
        started = time.monotonic()
        try:
            await self._bridge.wait_for_server(self._client, timeout_s)
        except ServiceUnavailableError:
            raise ActionUnavailableError(
                "absent", f"no action server on {self.name} within {timeout_s:g} s"
            ) from None
        loop = asyncio.get_running_loop()

        def feedback(msg: Any) -> None:  # executor thread
            if not loop.is_closed():
                loop.call_soon_threadsafe(on_feedback, msg.feedback)

        goal_id = uuid.uuid4().bytes  # known before the server answers: the watcher's "ours"
        with self._sent_mutex:
            self._sent.append(goal_id)
        sent = self._client.send_goal_async(
            goal, feedback_callback=feedback, goal_uuid=goal_uuid_msg(goal_id)
        )
        remaining = max(timeout_s - (time.monotonic() - started), timeout_s / 2)
        try:
            handle = await self._bridge.await_future(sent, remaining)
        except asyncio.CancelledError:
            sent.add_done_callback(self._cancel_if_accepted)  # never leave a goal we gave up on
            raise
        except ServiceTimeoutError:
            sent.add_done_callback(self._cancel_if_accepted)
            raise ActionUnavailableError(
                "silent", f"the action server on {self.name} did not answer within {timeout_s:g} s"
            ) from None
        if not handle.accepted:
            raise ActionUnavailableError(
                "rejected", f"the action server on {self.name} rejected the goal"
            )
        return ActionGoal(self._bridge, handle, goal_id)

    def _cancel_if_accepted(self, future: Any) -> None:
        """A goal accepted after we stopped waiting for the answer is canceled at once."""
        handle = future.result() if future.exception() is None else None
        if handle is not None and handle.accepted:
            logger.warning("action_late_goal_canceled", action=self.name)
            handle.cancel_goal_async()


def goal_uuid_msg(goal_id: bytes) -> Any:
    """A unique_identifier_msgs/UUID carrying ``goal_id`` (16 bytes)."""
    msg = GoalInfo().goal_id
    msg.uuid = list(goal_id)
    return msg
