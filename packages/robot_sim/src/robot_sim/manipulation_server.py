"""The gripper on ROS: ``robot_manipulation_interfaces`` Pick and Place action servers, the
latched ``HeldObject`` topic, and the subscriptions to every ``/vision/*/detections`` (found on
the graph, like a manipulation node that reads masks from the data plane).

- **goals**: one at a time (a goal while another runs is rejected, like a busy arm); every
  accepted goal runs in phases (time-scaled), each cut short by a cancel: the goal ends CANCELED
  and nothing changed in the world.
- **pick**: the rules of :class:`~robot_sim.gripper.Gripper` decide; on success the object
  leaves its place (``World.take``) and is held; ``on_world_changed`` then syncs the node's
  parameters and publishes the camera frame before the result is sent.
- **place** / release: what is held is put where the robot stands (``World.put``).
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import structlog
from builtin_interfaces.msg import Time
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from robot_manipulation_interfaces.action import Pick, Place
from robot_manipulation_interfaces.msg import HeldObject
from ros2_vision_interfaces.msg import VisionDetectionArray

from robot_sim.drive import DriveSim
from robot_sim.gripper import Gripper, Reference, Refusal, Sighting, Sightings
from robot_sim.manipulation_settings import ManipulationSettings

logger = structlog.get_logger(__name__)

DETECTIONS = re.compile(r"^/vision/[^/]+/detections$")
DETECTION_TYPE = "ros2_vision_interfaces/msg/VisionDetectionArray"
RESULT_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""The vision node's per-skill topics (latched): a late subscriber still gets the last result."""
HELD_QOS = RESULT_QOS
DETECTION_WAIT_S = 1.0
"""How long a pick waits for its detection result to arrive (goal and data plane race)."""
PICK_PHASES = ("locating", "approaching", "grasping", "lifting")
PLACE_PHASES = ("approaching", "placing", "releasing", "retracting")
LOCK_CHECK_S = 0.02
"""How often a running phase looks at the supervisor locks."""
HELD_TIMEOUT_S = 10.0
"""How long a lock may hold the arm before the goal gives up (like Nav2's progress checker)."""
_HELD = Refusal(
    "ARM_NOT_READY",
    "the arm stopped: a supervisor lock held it too long (no supervising brain, or a stop is "
    "latched)",
)


@dataclass
class _Goal:
    handle: Any
    wake: threading.Event = field(default_factory=threading.Event)
    cancel: bool = False


def ns_of(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class ManipulationServer:
    def __init__(
        self,
        node: Node,
        gripper: Gripper,
        drive: DriveSim,
        settings: ManipulationSettings,
        on_world_changed: Callable[[str], None],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._node = node
        self._gripper = gripper
        self._drive = drive
        self._settings = settings
        self._on_world_changed = on_world_changed
        self._clock = clock
        self._lock = threading.Lock()
        self._running: _Goal | None = None
        # the supervisor locks (robot-sim's twist_mux view): a held arm stops where it is and
        # goes on when the lock opens, or gives up after held_timeout_s (as the base does)
        self.held: Callable[[], bool] = lambda: False
        self.held_timeout_s = HELD_TIMEOUT_S
        self._since: Time = Time()
        self.sightings = Sightings()
        self._subscribed: dict[str, Any] = {}
        group = ReentrantCallbackGroup()
        self._held = node.create_publisher(HeldObject, settings.held_topic, HELD_QOS)
        self._pick = ActionServer(
            node,
            Pick,
            settings.pick_action,
            execute_callback=self._execute_pick,
            goal_callback=self._on_goal,
            cancel_callback=self._on_cancel,
            callback_group=group,
        )
        self._place = ActionServer(
            node,
            Place,
            settings.place_action,
            execute_callback=self._execute_place,
            goal_callback=self._on_goal,
            cancel_callback=self._on_cancel,
            callback_group=group,
        )
        discovery = MutuallyExclusiveCallbackGroup()
        node.create_timer(1.0 / settings.discovery_hz, self._discover, discovery)
        node.create_timer(1.0, self.publish_held, discovery)
        self.publish_held()

    def destroy(self) -> None:
        with self._lock:
            running = self._running
        if running is not None:
            running.cancel = True
            running.wake.set()
        self._pick.destroy()
        self._place.destroy()

    # -- the data plane -----------------------------------------------------------------------

    def _discover(self) -> None:
        """Subscribe each new ``/vision/<skill>/detections``; drop the subscriptions of topics
        gone from the graph (their results stay in the cache)."""
        present = {
            name
            for name, types in self._node.get_topic_names_and_types()
            if DETECTIONS.match(name) and DETECTION_TYPE in types
        }
        for name in present - set(self._subscribed):
            self._subscribed[name] = self._node.create_subscription(
                VisionDetectionArray, name, self._on_detections(name), RESULT_QOS
            )
            logger.info("detections_subscribed", topic=name)
        for name in set(self._subscribed) - present:
            self._node.destroy_subscription(self._subscribed.pop(name))

    def _on_detections(self, topic: str) -> Callable[[Any], None]:
        def keep(msg: Any) -> None:
            self.sightings.add(
                Sighting(
                    topic,
                    ns_of(msg.header.stamp),
                    tuple(str(d.label) for d in msg.detections),
                    tuple(float(d.score) for d in msg.detections),
                )
            )

        return keep

    def publish_held(self) -> None:
        self._held.publish(self._held_msg())

    def _held_msg(self) -> HeldObject:
        held = self._gripper.world.held()
        msg = HeldObject(holding=held is not None, label=held or "", since=self._since)
        msg.header.stamp = self._node.get_clock().now().to_msg()
        return msg

    # -- goals --------------------------------------------------------------------------------

    def _on_goal(self, request: Any) -> GoalResponse:
        kind = "pick" if hasattr(request, "target") else "place"
        with self._lock:
            if self._running is not None:
                logger.info("manipulation_goal_rejected", kind=kind, reason="another goal runs")
                return GoalResponse.REJECT
            self._running = _Goal(None)  # held until the goal ends
        logger.info("manipulation_goal_received", kind=kind)  # benchmarks read its timestamp
        return GoalResponse.ACCEPT

    def _on_cancel(self, _handle: Any) -> CancelResponse:
        with self._lock:
            running = self._running
        if running is not None:
            running.cancel = True
            running.wake.set()
        return CancelResponse.ACCEPT

    def _where(self) -> tuple[str | None, bool]:
        state = self._drive.state(self._clock())
        place = None if state.driving else self._drive.location_at(state.pose)
        return place, state.driving

    def _execute_pick(self, handle: Any) -> Any:
        with self._lock:
            goal = self._running or _Goal(handle)
            goal.handle = handle
        started = self._clock()
        try:
            return self._pick_goal(goal, started)
        finally:
            with self._lock:
                self._running = None

    def _pick_goal(self, goal: _Goal, started: float) -> Any:
        request = goal.handle.request
        target = request.target
        ref = Reference(target.topic, ns_of(target.stamp), int(target.index), str(target.label))
        place, driving = self._where()
        label = ""
        refusal = self._gripper.arm_ready(driving)
        deadline = self._clock() + DETECTION_WAIT_S
        while refusal is None or (refusal.not_yet and self._clock() < deadline and not goal.cancel):
            if refusal is not None:  # the result may still be on its way: look again shortly
                goal.wake.wait(0.02)
            now_ns = self._node.get_clock().now().nanoseconds
            sightings = self.sightings.of(ref.topic)
            label, refusal = self._gripper.resolve(ref, sightings, now_ns, float(request.max_age_s))
            if refusal is None:
                break
        if refusal is None:
            refusal = self._gripper.check_pick(place, label)
        logger.info("pick_accepted", topic=ref.topic, label=label or ref.label, place=place)
        if refusal is not None:
            return self._end_pick(goal, refusal, started)
        for n, phase in enumerate(PICK_PHASES):
            feedback = Pick.Feedback(phase=phase, progress=n / len(PICK_PHASES))
            if not self._phase(goal, feedback, self._settings.pick_s):
                if not goal.cancel:
                    return self._end_pick(goal, _HELD, started)
                return self._end_cancel(goal, Pick.Result(held=self._held_msg()), started, "pick")
            if phase == "grasping" and not self._gripper.grasp_holds():
                slipped = Refusal(
                    "GRASP_FAILED", f"the gripper closed on nothing: the {label} slipped"
                )
                return self._end_pick(goal, slipped, started)
        assert place is not None
        self._gripper.world.take(place, label)
        self._since = self._node.get_clock().now().to_msg()
        self._on_world_changed(place)
        self.publish_held()
        goal.handle.succeed()
        logger.info(
            "pick_succeeded",
            label=label,
            place=place,
            duration_ms=round(1000 * (self._clock() - started), 1),
        )
        return Pick.Result(error_code=Pick.Result.NONE, held=self._held_msg())

    def _end_pick(self, goal: _Goal, refusal: Refusal, started: float) -> Any:
        goal.handle.abort()
        logger.info(
            "pick_failed",
            error=refusal.code,
            detail=refusal.message,
            duration_ms=round(1000 * (self._clock() - started), 1),
        )
        return Pick.Result(
            error_code=getattr(Pick.Result, refusal.code),
            error_msg=refusal.message,
            held=self._held_msg(),
        )

    def _execute_place(self, handle: Any) -> Any:
        with self._lock:
            goal = self._running or _Goal(handle)
            goal.handle = handle
        started = self._clock()
        try:
            return self._place_goal(goal, started)
        finally:
            with self._lock:
                self._running = None

    def _place_goal(self, goal: _Goal, started: float) -> Any:
        place, driving = self._where()
        refusal = self._gripper.check_place(place, driving)
        if refusal is not None:
            return self._end_place(goal, refusal)
        for n, phase in enumerate(PLACE_PHASES):
            feedback = Place.Feedback(phase=phase, progress=n / len(PLACE_PHASES))
            if not self._phase(goal, feedback, self._settings.place_s):
                if not goal.cancel:
                    return self._end_place(goal, _HELD)
                return self._end_cancel(goal, Place.Result(held=self._held_msg()), started, "place")
        assert place is not None
        label = self._gripper.world.put(place)
        self._on_world_changed(place)
        self.publish_held()
        goal.handle.succeed()
        logger.info(
            "place_succeeded",
            label=label,
            place=place,
            mode=int(goal.handle.request.mode),
            duration_ms=round(1000 * (self._clock() - started), 1),
        )
        return Place.Result(error_code=Place.Result.NONE, placed_label=label, held=self._held_msg())

    def _end_place(self, goal: _Goal, refusal: Refusal) -> Any:
        goal.handle.abort()
        logger.info("place_failed", error=refusal.code, detail=refusal.message)
        return Place.Result(
            error_code=getattr(Place.Result, refusal.code),
            error_msg=refusal.message,
            held=self._held_msg(),
        )

    def _phase(self, goal: _Goal, feedback: Any, total_s: float) -> bool:
        """Publish the phase and spend its share of the time; False when canceled, or when a
        supervisor lock held the arm longer than ``held_timeout_s`` (the phase's time does not
        run while it is held; looked at every ``LOCK_CHECK_S``)."""
        if not self._while_held(goal):
            return False
        goal.handle.publish_feedback(feedback)
        left = total_s / len(PICK_PHASES) / self._settings.time_scale
        while left > 0 and not goal.cancel:
            if not self._while_held(goal):
                return False
            step = min(left, LOCK_CHECK_S)
            goal.wake.wait(step)
            left -= step
        return not goal.cancel

    def _while_held(self, goal: _Goal) -> bool:
        """Wait while a lock holds the arm: True once it is free, False on a cancel or when the
        hold outlasted ``held_timeout_s``."""
        since = self._clock()
        while self.held() and not goal.cancel:
            if self._clock() - since >= self.held_timeout_s:
                return False
            goal.wake.wait(LOCK_CHECK_S)
        return not goal.cancel

    def _end_cancel(self, goal: _Goal, result: Any, started: float, what: str) -> Any:
        deadline = self._clock() + 1.0
        while not goal.handle.is_cancel_requested and self._clock() < deadline:
            goal.wake.wait(0.002)  # rclpy marks the goal CANCELING right after our callback
        if goal.handle.is_cancel_requested:
            goal.handle.canceled()
        else:  # shutdown: no cancel request reached the goal
            goal.handle.abort()
        logger.info(f"{what}_canceled", duration_ms=round(1000 * (self._clock() - started), 1))
        return result
