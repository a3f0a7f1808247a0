"""Nav2MotionBase: drives the robot through Nav2's NavigateToPose action (the Nav2Action port).

- The goal is the location's pose in the map's frame (``map``). A goal is taken only once the
  action server accepted it; an absent server or a rejected goal is BaseUnavailableError
  (nothing moved), and the next drive tries again, so Nav2 may start before or after us.
- Feedback → DriveProgress; SUCCEEDED → arrived; ABORTED → failed with Nav2's error code
  mapped to a named failure (``error_codes.py``); CANCELED → stopped.
- ``stop`` cancels the goal and waits (bounded by ``cancel_timeout_s``) until the server
  reports it canceled.
- The pose is the pose topic's latest message, or the feedback's ``current_pose`` while
  driving (whichever is newer).
- **A lost base** (issue 27): Nav2's bt_navigator sends NavigateToPose feedback on every
  behaviour-tree tick (``bt_loop_duration``, 10 ms by default; robot-sim at 10 Hz), so
  ``feedback_timeout_s`` (3 s) without feedback while a goal runs means the action server is
  gone (killed, crashed, its host down): the drive ends ``BASE_UNAVAILABLE`` at once (a cancel
  is still sent, unawaited, in case it was only stalled). Waiting for the result would wait
  forever, and the server's disappearance from the ROS graph takes Fast DDS's participant
  lease (up to 20 s) to show. From then on the pose is **stale** until a pose arrives again.
- ``pose_status``: stale with no pose yet, since a lost base, or older than ``pose_max_age_s``
  (0: no age limit; AMCL publishes only when it updates, so a robot with AMCL leaves it 0);
  a pose that came back far from where it was last seen is reported as ``relocated``.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Mapping
from typing import Any

import structlog

from robot_mcp_navigation.motion.base import (
    BaseUnavailableError,
    DriveFailure,
    DriveGoal,
    DriveProgress,
    DriveResult,
    MotionBase,
    MotionBusyError,
    Pose,
    PoseStatus,
    ProgressCallback,
)
from robot_mcp_navigation.motion.nav2.error_codes import drive_failure
from robot_mcp_navigation.motion.nav2.port import (
    Nav2Action,
    Nav2Feedback,
    Nav2Goal,
    Nav2Outcome,
    Nav2UnavailableError,
)

logger = structlog.get_logger(__name__)

BASE_UNAVAILABLE = "BASE_UNAVAILABLE"
RELOCATION_SHOWN_S = 300.0
"""How long get_pose keeps reporting a relocation."""
STALE_GOALS_TIMEOUT_S = 3.0
"""How long start-up looks for Nav2 to cancel stale goals (none up: nothing to cancel)."""
LATE_POSE_S = 2.0
"""A pose taken in this long after the base was declared lost is still a lost base's: on a
starved host the pose sent before robot-sim was killed can reach our callback after the feedback
timeout ran out (a fresh-clone CI run said "5 s old" instead of "stopped answering")."""


class Nav2MotionBase(MotionBase):
    at_location_tolerance_m = 0.3  # Nav2 stops within its goal tolerance (0.25 m default)

    def __init__(
        self,
        action: Nav2Action,
        *,
        frame: str,
        speed_mps: float,
        initial_pose: Pose,
        site_hints: Mapping[str, tuple[str, ...]] | None = None,
        server_timeout_s: float = 5.0,
        cancel_timeout_s: float = 5.0,
        feedback_timeout_s: float = 3.0,
        pose_max_age_s: float = 0.0,
    ) -> None:
        if speed_mps <= 0 or server_timeout_s <= 0 or cancel_timeout_s <= 0:
            raise ValueError("speed_mps, server_timeout_s and cancel_timeout_s must be positive")
        if feedback_timeout_s < 0 or pose_max_age_s < 0:
            raise ValueError("feedback_timeout_s and pose_max_age_s must be >= 0 (0: off)")
        self._action = action
        self._frame = frame
        self._speed = speed_mps
        self._fallback_pose = initial_pose
        self._site_hints = dict(site_hints or {})
        self._server_timeout_s = server_timeout_s
        self._cancel_timeout_s = cancel_timeout_s
        self._driving = False
        self._stop_requested = False
        self._goal: asyncio.Future[Nav2Goal | None] | None = None
        self._follow: asyncio.Task[DriveResult] | None = None
        self._cancel_sent: Nav2Goal | None = None
        self._feedback_pose: tuple[float, Pose] | None = None  # (monotonic time, pose)
        self._warned_no_pose = False
        self._feedback_timeout_s = feedback_timeout_s
        self._pose_max_age_s = pose_max_age_s
        self._lost_at: float | None = None  # when the base stopped answering a goal
        self._drive_ended_at = 0.0  # monotonic; a pose gap while driving is no relocation
        self._background: set[asyncio.Task[None]] = set()

    @property
    def driving(self) -> bool:
        return self._driving

    # -- queries ---------------------------------------------------------------------------

    def current_pose(self) -> Pose:
        topic = self._action.latest_pose()
        if self._feedback_pose is not None and (
            topic is None or self._feedback_pose[0] >= topic.received_at
        ):
            return self._feedback_pose[1]
        if topic is not None:
            return topic.pose
        if not self._warned_no_pose:
            self._warned_no_pose = True
            logger.warning("pose_unknown", detail="no pose message yet; using the map's start")
        return self._fallback_pose

    def estimate_duration_s(self, goal: Pose) -> float:
        return self.current_pose().distance_to(goal) / self._speed

    def _newest_pose_at(self) -> float | None:
        times = []
        topic = self._action.latest_pose()
        if topic is not None:
            times.append(topic.received_at)
        if self._feedback_pose is not None:
            times.append(self._feedback_pose[0])
        return max(times, default=None)

    def pose_status(self) -> PoseStatus:
        now = time.monotonic()
        newest = self._newest_pose_at()
        if newest is None:
            return PoseStatus(
                True, None, "no pose from the robot base yet: showing the map's start"
            )
        age = now - newest
        relocated = self._relocated(now)
        stale: str | None = None
        if self._lost_at is not None and newest < self._lost_at + LATE_POSE_S:
            stale = (
                f"no pose from the robot base since it stopped answering "
                f"{now - self._lost_at:.0f} s ago: this is where it was last seen"
            )
        elif self._pose_max_age_s and age > self._pose_max_age_s:
            stale = f"the last pose from the robot base is {age:.0f} s old"
        if stale is not None:
            return PoseStatus(True, age, stale, relocated)
        came_back = None
        if relocated is not None:
            came_back = (
                f"the robot base came back {relocated['distance_m']:.1f} m from where it was "
                f"last seen, {relocated['ago_s']:.0f} s ago"
            )
        return PoseStatus(False, age, came_back, relocated)

    def _relocated(self, now: float) -> dict[str, Any] | None:
        """A relocation worth saying: the base came back after it was lost, or the pose
        jumped while the robot stood idle (a restart, a re-localisation). A gap in the pose
        topic during a drive (a loaded host) is no relocation: the robot was moving."""
        moved = self._action.last_relocation()
        if moved is None or now - moved.at > RELOCATION_SHOWN_S:
            return None
        silence_began = moved.at - moved.silent_s
        lost_meanwhile = self._lost_at is not None and silence_began <= self._lost_at <= moved.at
        idle = not self._driving and silence_began >= self._drive_ended_at
        if not (lost_meanwhile or idle):
            return None
        return {
            "from": {"x": round(moved.before.x, 2), "y": round(moved.before.y, 2)},
            "to": {"x": round(moved.after.x, 2), "y": round(moved.after.y, 2)},
            "distance_m": round(moved.distance_m, 2),
            "ago_s": round(now - moved.at, 1),
        }

    # -- commands --------------------------------------------------------------------------

    async def cancel_stale_goals(self) -> None:
        """A goal the killed process before us sent is still Nav2's (an action server does not
        drop a goal whose client died): once our lease opens the lock the robot would drive
        on with no one supervising it. Cancel every goal at start-up, before the lock opens."""
        started = time.monotonic()
        timeout = min(self._server_timeout_s, STALE_GOALS_TIMEOUT_S)
        canceled = await self._action.cancel_all(timeout)
        logger.info(
            "nav2_stale_goals_canceled" if canceled is not None else "nav2_stale_goals_unchecked",
            canceled=canceled,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )

    async def drive_to(self, goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        return await (await self.start_drive(goal, on_progress))

    async def start_drive(
        self, goal: DriveGoal, on_progress: ProgressCallback
    ) -> asyncio.Future[DriveResult]:
        if self._driving:
            raise MotionBusyError("a Nav2 goal is already running")
        self._driving = True
        self._stop_requested = False
        self._feedback_pose = None
        loop = asyncio.get_running_loop()
        accepted: asyncio.Future[Nav2Goal | None] = loop.create_future()
        self._goal = accepted
        queue: asyncio.Queue[Nav2Feedback | Nav2Outcome] = asyncio.Queue()
        started = time.monotonic()
        try:
            handle = await self._action.send_goal(
                goal.pose, self._frame, queue.put_nowait, self._server_timeout_s
            )
        except Nav2UnavailableError as exc:
            accepted.set_result(None)
            self._driving = False
            raise BaseUnavailableError(exc.detail) from exc
        except BaseException:
            accepted.set_result(None)
            self._driving = False
            raise
        accepted.set_result(handle)
        logger.info(
            "nav2_goal_accepted",
            goal=goal.name,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        self._follow = asyncio.create_task(
            self._follow_goal(goal, handle, queue, on_progress), name=f"nav2-{goal.name}"
        )
        if self._stop_requested:  # stop() came while the goal was being accepted
            await self._cancel(handle)
        return self._follow

    async def stop(self) -> None:
        if not self._driving:
            return
        self._stop_requested = True
        started = time.monotonic()
        try:
            async with asyncio.timeout(self._cancel_timeout_s):
                assert self._goal is not None
                handle = await asyncio.shield(self._goal)
                if handle is None:
                    return  # the goal never ran
                await self._cancel(handle)
                if self._follow is not None:
                    await asyncio.shield(self._follow)
        except TimeoutError:
            logger.warning(
                "nav2_cancel_unconfirmed",
                detail=f"Nav2 did not report the goal canceled within {self._cancel_timeout_s} s",
            )
            return
        logger.info("nav2_goal_canceled", duration_ms=round((time.monotonic() - started) * 1000, 1))

    # -- the drive ------------------------------------------------------------------------

    async def _cancel(self, handle: Nav2Goal) -> None:
        """Ask the server once per goal to cancel it."""
        if self._cancel_sent is handle:
            return
        self._cancel_sent = handle
        if not await handle.cancel(self._cancel_timeout_s):
            logger.warning("nav2_cancel_refused")

    async def _follow_goal(
        self,
        goal: DriveGoal,
        handle: Nav2Goal,
        queue: asyncio.Queue[Nav2Feedback | Nav2Outcome],
        on_progress: ProgressCallback,
    ) -> DriveResult:
        waiter = asyncio.create_task(_outcome_into(handle, queue))
        origin = self.current_pose()
        total = origin.distance_to(goal.pose)
        elapsed = 0.0
        try:
            while True:
                try:
                    async with asyncio.timeout(self._feedback_timeout_s or None):
                        item = await queue.get()
                except TimeoutError:
                    return self._base_lost(goal, handle, elapsed)
                if isinstance(item, Nav2Outcome):
                    return self._result(goal, item, elapsed)
                elapsed = item.navigation_time_s
                self._feedback_pose = (time.monotonic(), item.pose)
                total = max(total, item.distance_remaining_m)
                if self._stop_requested:
                    continue  # no progress after a stop was asked for
                eta = item.eta_s
                if eta <= 0 < item.distance_remaining_m:
                    eta = item.distance_remaining_m / self._speed  # Nav2 has no estimate yet
                await on_progress(
                    DriveProgress(item.pose, total, item.distance_remaining_m, eta, elapsed)
                )
        except asyncio.CancelledError:
            # The caller gave up on this drive (its timeout): the robot must not keep going.
            with contextlib.suppress(Exception):
                await self._cancel(handle)
            raise
        finally:
            waiter.cancel()
            self._driving = False
            self._drive_ended_at = time.monotonic()
            self._goal = None

    def _base_lost(self, goal: DriveGoal, handle: Nav2Goal, elapsed: float) -> DriveResult:
        """No feedback for ``feedback_timeout_s``: the action server is gone."""
        self._lost_at = time.monotonic()
        logger.error(
            "nav2_base_lost",
            goal=goal.name,
            feedback_timeout_s=self._feedback_timeout_s,
            detail="no NavigateToPose feedback: the action server stopped answering",
        )
        cancel = asyncio.create_task(self._cancel_quietly(handle))  # in case it only stalled
        self._background.add(cancel)
        cancel.add_done_callback(self._background.discard)
        return DriveResult(
            "failed",
            self.current_pose(),
            elapsed,
            DriveFailure(
                BASE_UNAVAILABLE,
                f"lost contact with the robot base on the way to {goal.name}: its navigation "
                f"stack sent nothing for {self._feedback_timeout_s:g} s (stopped or restarting)",
                recoverable=True,
                suggestions=[
                    "ask an operator to check the robot base",
                    "once get_pose shows a fresh pose again, call navigate_to again",
                ],
            ),
        )

    async def _cancel_quietly(self, handle: Nav2Goal) -> None:
        try:
            await self._cancel(handle)
        except Exception:  # the server is gone: nothing more to do
            logger.info("nav2_cancel_unanswered")

    def _result(self, goal: DriveGoal, outcome: Nav2Outcome, elapsed: float) -> DriveResult:
        pose = self.current_pose()
        logger.info(
            "nav2_goal_finished",
            goal=goal.name,
            status=outcome.status,
            error_code=outcome.error_code,
            error_msg=outcome.error_msg,
        )
        if outcome.status == "succeeded":
            return DriveResult("arrived", pose, elapsed)
        if outcome.status == "canceled":
            return DriveResult("stopped", pose, elapsed)
        if outcome.status == "aborted":
            failure = drive_failure(
                outcome.error_code,
                outcome.error_msg,
                goal.name,
                self._site_hints.get(goal.name, ()),
            )
            return DriveResult("failed", pose, elapsed, failure)
        return DriveResult(
            "failed",
            pose,
            elapsed,
            DriveFailure(
                "BASE_ERROR",
                f"lost track of the Nav2 goal to {goal.name} ({outcome.error_msg or 'no result'})",
                recoverable=False,
                suggestions=["call get_pose, then ask an operator whether the robot is moving"],
            ),
        )


async def _outcome_into(handle: Nav2Goal, queue: asyncio.Queue[Nav2Feedback | Nav2Outcome]) -> None:
    """Queue the goal's outcome behind the feedback that came before it."""
    try:
        outcome = await handle.outcome()
    except Exception as exc:  # the ROS side is a boundary: an error ends the drive, cleanly
        logger.exception("nav2_result_failed")
        outcome = Nav2Outcome("unknown", error_msg=str(exc) or type(exc).__name__)
    queue.put_nowait(outcome)
