"""``nav2_msgs/action/NavigateToPose`` served the way Nav2's bt_navigator serves it.

- **accept / reject**: like Nav2, every well-formed goal is accepted while the navigator is
  active; an inactive navigator (parameter ``active: false``, a Nav2 whose lifecycle is not
  active) rejects goals, and so does a goal whose pose is not finite. Problems Nav2 finds
  after accepting end the goal ABORTED with its codes: a frame other than ``map`` →
  ``TF_ERROR`` (9002); a ``behavior_tree`` (the sim runs none) → ``FAILED_TO_LOAD_BEHAVIOR_TREE``.
- **feedback** at ``feedback_hz`` (10): ``current_pose``, ``distance_remaining``,
  ``estimated_time_remaining`` and ``navigation_time`` in robot seconds (wall × time scale),
  ``number_of_recoveries`` (0: the sim never runs recovery behaviours).
- **cancel**: always accepted; the robot halts and the goal ends CANCELED.
- **preemption**: a new goal replaces the running one (Nav2's ``accept_pending_goal``); the
  robot turns toward the new goal at once and the old goal ends ABORTED with ``NONE``.
- **the camera first**: when the robot stops (arrived, failed, canceled), ``on_stopped`` runs
  before the goal's result is sent, so the camera frame of where the robot now stands is on
  the wire before any client learns the robot stopped (a skill started on arrival never sees
  the corridor view of the drive).
- **no way through**: the drive plans on the robot's costmap and replans when the robot sees
  a door closed (``drive.py``); when no path is left the goal ends ABORTED with the planner's
  code (``NO_VALID_PATH`` 208, as bt_navigator passes ComputePathToPose's code on) where the
  robot stands. A scripted ``failures:`` entry of a map (unit tests) aborts the same way.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import structlog
from nav2_msgs.action import NavigateToPose
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from robot_sim import messages
from robot_sim.drive import DriveSim, DriveState

logger = structlog.get_logger(__name__)

FAILED_TO_MAKE_PROGRESS = 105
"""``nav2_msgs/action/FollowPath`` FAILED_TO_MAKE_PROGRESS: what Nav2's controller reports when
its progress checker sees the robot not moving (a twist_mux lock holding the base)."""
HELD_MESSAGE = "Failed to make progress: the base's velocity commands are held by its lock"
PROGRESS_TIMEOUT_S = 10.0
"""Nav2's progress checker ``movement_time_allowance`` (default 10 s): how long a goal waits for a
base held by its lock before it is aborted FAILED_TO_MAKE_PROGRESS."""

NO_VALID_PATH = 208
"""``nav2_msgs/action/ComputePathToPose`` NO_VALID_PATH (Nav2 1.4, Kilted): bt_navigator
reports the failing planner's code in NavigateToPose's ``error_code``."""

CANCEL_SETTLE_S = 1.0
"""How long the goal loop waits for rclpy to mark an accepted cancel (CANCELING)."""


@dataclass
class _Run:
    handle: Any
    wake: threading.Event = field(default_factory=threading.Event)
    cancel: bool = False
    location: str | None = None


class NavigateToPoseServer:
    """The action server; ``drive`` moves the robot, ``clock`` is the wall clock (seconds)."""

    def __init__(
        self,
        node: Node,
        drive: DriveSim,
        action_name: str,
        feedback_hz: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
        on_stopped: Callable[[], None] | None = None,
    ) -> None:
        self._node = node
        self._on_stopped = on_stopped
        self._drive = drive
        self._clock = clock
        self.feedback_period_s = 1.0 / feedback_hz
        self._lock = threading.Lock()
        self._active: _Run | None = None
        self._runs: dict[bytes, _Run] = {}
        self.accepting = True
        self.held: Callable[[], bool] = lambda: False  # the supervisor lock holds the base
        self.progress_timeout_s = PROGRESS_TIMEOUT_S
        self._server = ActionServer(
            node,
            NavigateToPose,
            action_name,
            execute_callback=self._execute,
            goal_callback=self._on_goal,
            handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel,
            callback_group=ReentrantCallbackGroup(),
        )

    def destroy(self) -> None:
        with self._lock:
            runs = list(self._runs.values())
        for run in runs:
            run.cancel = True
            run.wake.set()
        self._server.destroy()

    def wake(self) -> None:
        """Look at the drive now (the supervisor lock halted it)."""
        with self._lock:
            run = self._active
        if run is not None:
            run.wake.set()

    @property
    def driving(self) -> bool:
        return self._drive.state(self._clock()).driving

    def _on_goal(self, goal: Any) -> GoalResponse:
        position = goal.pose.pose.position
        finite = all(math.isfinite(v) for v in (position.x, position.y, position.z))
        if not self.accepting or not finite:
            reason = "navigator inactive" if not self.accepting else "pose is not finite"
            logger.info("goal_rejected", reason=reason)
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_accepted(self, handle: Any) -> None:
        run = _Run(handle)
        with self._lock:
            previous = self._active
            self._active = run
            self._runs[bytes(handle.goal_id.uuid)] = run
        if previous is not None:
            previous.wake.set()
        handle.execute()

    def _on_cancel(self, handle: Any) -> CancelResponse:
        with self._lock:
            run = self._runs.get(bytes(handle.goal_id.uuid))
        if run is not None:
            run.cancel = True
            run.wake.set()
        return CancelResponse.ACCEPT

    def _execute(self, handle: Any) -> Any:
        with self._lock:
            run = self._runs[bytes(handle.goal_id.uuid)]
        try:
            return self._drive_goal(run)
        finally:
            with self._lock:
                self._runs.pop(bytes(handle.goal_id.uuid), None)
                if self._active is run:
                    self._active = None

    def _drive_goal(self, run: _Run) -> Any:
        handle, request = run.handle, run.handle.request
        frame = request.pose.header.frame_id
        if frame not in ("", messages.MAP_FRAME) or request.behavior_tree:
            self._halt_if_active(run)
        if frame not in ("", messages.MAP_FRAME):
            return self._abort(
                run, NavigateToPose.Result.TF_ERROR, f"no transform from {frame!r} to map"
            )
        if request.behavior_tree:
            return self._abort(
                run,
                NavigateToPose.Result.FAILED_TO_LOAD_BEHAVIOR_TREE,
                f"behavior tree {request.behavior_tree!r} not loaded: the sim runs none",
            )
        goal = messages.pose_from_msg(request.pose.pose)
        if self.held():  # accepted; the controller's commands go nowhere until the lock opens
            self._halt_if_active(run)
            ended = self._hold(run, self._clock())
            if ended is not None:
                return ended
        with self._lock:
            if self._active is not run:
                return self._abort(run, NavigateToPose.Result.NONE, "preempted by a newer goal")
            first = self._drive.start(goal, self._clock())
        run.location = self._drive.location_at(goal)
        logger.info(
            "goal_accepted",
            x=round(goal.x, 2),
            y=round(goal.y, 2),
            location=run.location,
            distance_m=round(first.distance_remaining_m, 2),
            via=[[round(x, 2), round(y, 2)] for x, y in first.plan],  # the plan it drives
        )
        started = self._clock()
        while True:
            with self._lock:
                preempted = self._active is not run
                state = self._drive.state(self._clock())
            if preempted:
                return self._abort(run, NavigateToPose.Result.NONE, "preempted by a newer goal")
            if run.cancel:
                return self._cancel(run, started)
            handle.publish_feedback(self._feedback(state))
            if state.status == "arrived":
                return self._finish(run, started, state.replans)
            if state.status == "failed":
                self._stopped()
                code = state.error_code or NO_VALID_PATH
                return self._abort(run, code, state.error_msg or "no valid path")
            if state.status == "halted":  # the supervisor lock stopped the base
                ended = self._hold(run, started)
                if ended is not None:
                    return ended
                with self._lock:  # the lock opened: Nav2's controller drives on to the goal
                    if self._active is run:
                        self._drive.start(goal, self._clock())
                continue
            run.wake.wait(self.feedback_period_s)
            run.wake.clear()

    def _hold(self, run: _Run, started: float) -> Any | None:
        """While the lock holds the base, the goal stays (Nav2 does not see twist_mux): no
        progress, feedback goes on; None once the lock opens, else how the goal ended — the
        progress checker's FAILED_TO_MAKE_PROGRESS after ``progress_timeout_s``, a cancel or a
        newer goal."""
        since = self._clock()
        while self.held():
            with self._lock:
                preempted = self._active is not run
                state = self._drive.state(self._clock())
            if preempted:
                return self._abort(run, NavigateToPose.Result.NONE, "preempted by a newer goal")
            if run.cancel:
                return self._cancel(run, started)
            if self._clock() - since >= self.progress_timeout_s:
                self._stopped()
                return self._abort(run, FAILED_TO_MAKE_PROGRESS, HELD_MESSAGE)
            run.handle.publish_feedback(self._feedback(state))
            run.wake.wait(self.feedback_period_s)
            run.wake.clear()
        return None

    def _halt_if_active(self, run: _Run) -> None:
        """A goal that ends before driving leaves no earlier (preempted) route running."""
        with self._lock:
            if self._active is run:
                self._drive.halt(self._clock())

    def _feedback(self, state: DriveState) -> Any:
        feedback = NavigateToPose.Feedback()
        stamp = self._node.get_clock().now().to_msg()
        feedback.current_pose = messages.pose_stamped(state.pose, stamp)
        feedback.navigation_time = messages.seconds_to_duration(state.elapsed_s)
        feedback.estimated_time_remaining = messages.seconds_to_duration(state.eta_s)
        feedback.number_of_recoveries = 0
        feedback.distance_remaining = float(state.distance_remaining_m)
        return feedback

    def _stopped(self) -> None:
        if self._on_stopped is not None:
            self._on_stopped()

    def _finish(self, run: _Run, started: float, replans: int = 0) -> Any:
        self._stopped()
        run.handle.succeed()
        logger.info(
            "goal_succeeded",
            location=run.location,
            replans=replans,
            duration_ms=round(1000 * (self._clock() - started), 1),
        )
        return NavigateToPose.Result(error_code=NavigateToPose.Result.NONE)

    def _cancel(self, run: _Run, started: float) -> Any:
        self._drive.halt(self._clock())
        self._stopped()
        deadline = self._clock() + CANCEL_SETTLE_S
        while not run.handle.is_cancel_requested and self._clock() < deadline:
            run.wake.wait(0.002)  # rclpy marks the goal CANCELING right after our callback
        if run.handle.is_cancel_requested:
            run.handle.canceled()
            outcome = "canceled"
        else:  # shutdown: no cancel request reached the goal, end it the other legal way
            run.handle.abort()
            outcome = "aborted_on_shutdown"
        logger.info(
            "goal_canceled",
            outcome=outcome,
            location=run.location,
            duration_ms=round(1000 * (self._clock() - started), 1),
        )
        return NavigateToPose.Result(error_code=NavigateToPose.Result.NONE)

    def _abort(self, run: _Run, code: int, message: str) -> Any:
        run.handle.abort()
        logger.info("goal_aborted", error_code=code, error_msg=message, location=run.location)
        return NavigateToPose.Result(error_code=code, error_msg=message)
