"""The pick and place actions built from the wheels work end to end in rclpy: a pick goal that
refers to a detection → feedback → SUCCEEDED with what is held, ABORTED with a named error code,
CANCELED; a place and a release; the latched held-object topic."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Time
from rclpy.action import ActionClient, ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from robot_manipulation_interfaces.action import Pick, Place
from robot_manipulation_interfaces.msg import DetectionRef, HeldObject

pytestmark = pytest.mark.ros

TIMEOUT_S = 10.0
LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


class Arm:
    """Pick succeeds for label "package", fails with GRASP_FAILED for "slippery", runs until
    canceled for "slow"; place answers NOTHING_HELD when empty."""

    def __init__(self, node: Node) -> None:
        self.held = ""
        self.goals: list[Any] = []
        group = ReentrantCallbackGroup()
        self.held_pub = node.create_publisher(HeldObject, "/manipulation/held", LATCHED)
        self.pick = ActionServer(
            node,
            Pick,
            "/manipulation/pick",
            self.execute_pick,
            cancel_callback=lambda _r: CancelResponse.ACCEPT,
            callback_group=group,
        )
        self.place = ActionServer(
            node, Place, "/manipulation/place", self.execute_place, callback_group=group
        )

    def held_msg(self) -> HeldObject:
        return HeldObject(holding=bool(self.held), label=self.held, since=Time(sec=7))

    def execute_pick(self, goal: ServerGoalHandle) -> Any:
        self.goals.append(goal.request)
        label = goal.request.target.label
        result = Pick.Result()
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline:
            goal.publish_feedback(Pick.Feedback(phase="grasping", progress=0.5))
            if goal.is_cancel_requested:
                goal.canceled()
                result.held = self.held_msg()
                return result
            if label == "slippery":
                result.error_code = Pick.Result.GRASP_FAILED
                result.error_msg = "the gripper closed on nothing"
                goal.abort()
                return result
            if label == "package":
                self.held = label
                self.held_pub.publish(self.held_msg())
                result.held = self.held_msg()
                goal.succeed()
                return result
            time.sleep(0.02)  # "slow": a 50 Hz control loop until canceled or the deadline
        goal.abort()
        return result

    def execute_place(self, goal: ServerGoalHandle) -> Any:
        result = Place.Result()
        if not self.held:
            result.error_code = Place.Result.NOTHING_HELD
            goal.abort()
            return result
        result.placed_label, self.held = self.held, ""
        result.held = self.held_msg()
        self.held_pub.publish(self.held_msg())
        goal.succeed()
        return result


@pytest.fixture
def ros() -> Iterator[tuple[Node, Arm, ActionClient, ActionClient]]:
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("manipulation_round_trip", context=context)
    executor = MultiThreadedExecutor(context=context)
    executor.add_node(node)
    arm = Arm(node)
    pick = ActionClient(node, Pick, "/manipulation/pick")
    place = ActionClient(node, Place, "/manipulation/place")
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        assert pick.wait_for_server(timeout_sec=TIMEOUT_S)
        assert place.wait_for_server(timeout_sec=TIMEOUT_S)
        yield node, arm, pick, place
    finally:
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=2.0)


def pick_goal(label: str) -> Any:
    target = DetectionRef(
        topic="/vision/find_object/detections", stamp=Time(sec=1_700_000_000, nanosec=5), label=label
    )
    return Pick.Goal(target=target, max_age_s=5.0)


def wait(future: Any) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    assert done.wait(TIMEOUT_S), "no answer from the action server"
    return future.result()


def test_a_detection_reference_defaults_to_the_best_match_and_place_to_placing() -> None:
    assert DetectionRef().index == -1
    assert Pick.Goal().max_age_s == 0.0
    assert Place.Goal().mode == Place.Goal.PLACE
    assert Place.Goal.RELEASE == 1


def test_pick_goal_carries_the_detection_reference_and_the_result_what_is_held(
    ros: tuple[Node, Arm, ActionClient, ActionClient],
) -> None:
    _node, arm, pick, _place = ros
    feedback: list[Any] = []
    handle = wait(pick.send_goal_async(pick_goal("package"), feedback_callback=feedback.append))
    assert handle.accepted
    outcome = wait(handle.get_result_async())
    assert outcome.status == GoalStatus.STATUS_SUCCEEDED
    assert outcome.result.error_code == Pick.Result.NONE
    assert outcome.result.held.holding
    assert outcome.result.held.label == "package"
    assert outcome.result.held.since.sec == 7
    sent = arm.goals[0].target
    assert sent.topic == "/vision/find_object/detections"
    assert (sent.stamp.sec, sent.stamp.nanosec, sent.index) == (1_700_000_000, 5, -1)
    assert feedback[0].feedback.phase == "grasping"


def test_a_failed_grasp_aborts_with_its_error_code(
    ros: tuple[Node, Arm, ActionClient, ActionClient],
) -> None:
    _node, _arm, pick, _place = ros
    handle = wait(pick.send_goal_async(pick_goal("slippery")))
    outcome = wait(handle.get_result_async())
    assert outcome.status == GoalStatus.STATUS_ABORTED
    assert outcome.result.error_code == Pick.Result.GRASP_FAILED
    assert outcome.result.error_msg == "the gripper closed on nothing"


def test_cancel_reaches_a_running_pick(ros: tuple[Node, Arm, ActionClient, ActionClient]) -> None:
    _node, _arm, pick, _place = ros
    feedback = threading.Event()
    handle = wait(
        pick.send_goal_async(pick_goal("slow"), feedback_callback=lambda _m: feedback.set())
    )
    assert feedback.wait(TIMEOUT_S)
    cancel = wait(handle.cancel_goal_async())
    assert len(cancel.goals_canceling) == 1
    assert wait(handle.get_result_async()).status == GoalStatus.STATUS_CANCELED


def test_place_puts_down_what_is_held_and_the_held_topic_latches_it(
    ros: tuple[Node, Arm, ActionClient, ActionClient],
) -> None:
    node, _arm, pick, place = ros
    empty = wait(wait(place.send_goal_async(Place.Goal())).get_result_async())
    assert empty.status == GoalStatus.STATUS_ABORTED
    assert empty.result.error_code == Place.Result.NOTHING_HELD
    wait(wait(pick.send_goal_async(pick_goal("package"))).get_result_async())
    latched: list[HeldObject] = []
    got = threading.Event()
    node.create_subscription(
        HeldObject, "/manipulation/held", lambda m: (latched.append(m), got.set()), LATCHED
    )
    assert got.wait(TIMEOUT_S), "a late subscriber gets the last held object"
    assert latched[-1].label == "package"
    done = wait(wait(place.send_goal_async(Place.Goal(mode=Place.Goal.RELEASE))).get_result_async())
    assert done.status == GoalStatus.STATUS_SUCCEEDED
    assert done.result.placed_label == "package"
    assert not done.result.held.holding
