"""The NavigateToPose action built from the wheels works end to end in rclpy: goal → feedback →
SUCCEEDED, ABORTED with Nav2's error code, and CANCELED."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from action_msgs.msg import GoalStatus
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient, ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

pytestmark = pytest.mark.ros

TIMEOUT_S = 10.0


class Server:
    """A NavigateToPose server whose outcome follows the goal's behavior_tree field."""

    def __init__(self, node: Node) -> None:
        self.cancel_seen = threading.Event()
        self.server = ActionServer(
            node,
            NavigateToPose,
            "/navigate_to_pose",
            self.execute,
            cancel_callback=lambda _request: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup(),
        )

    def execute(self, goal: ServerGoalHandle) -> Any:
        result = NavigateToPose.Result()
        mode = goal.request.behavior_tree
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline:
            feedback = NavigateToPose.Feedback()
            feedback.current_pose = goal.request.pose
            feedback.distance_remaining = 1.5
            feedback.number_of_recoveries = 2
            goal.publish_feedback(feedback)
            if goal.is_cancel_requested:
                self.cancel_seen.set()
                goal.canceled()
                return result
            if mode == "succeed":
                goal.succeed()
                return result
            if mode == "abort":
                result.error_code = NavigateToPose.Result.TIMEOUT
                result.error_msg = "navigation timed out"
                goal.abort()
                return result
            time.sleep(0.02)  # "run": a 50 Hz control loop until canceled or the deadline
        goal.abort()
        return result


@pytest.fixture
def client() -> Iterator[ActionClient]:
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("nav2_msgs_round_trip", context=context)
    executor = MultiThreadedExecutor(context=context)
    executor.add_node(node)
    Server(node)
    action_client = ActionClient(node, NavigateToPose, "/navigate_to_pose")
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        assert action_client.wait_for_server(timeout_sec=TIMEOUT_S)
        yield action_client
    finally:
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=2.0)


def goal(mode: str) -> Any:
    request = NavigateToPose.Goal()
    request.pose.header.frame_id = "map"
    request.pose.pose.position.x = 3.0
    request.pose.pose.orientation.w = 1.0
    request.behavior_tree = mode
    return request


def wait(future: Any) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    assert done.wait(TIMEOUT_S), "no answer from the action server"
    return future.result()


def test_goal_feedback_and_success(client: ActionClient) -> None:
    feedback: list[Any] = []
    handle = wait(client.send_goal_async(goal("succeed"), feedback_callback=feedback.append))
    assert handle.accepted
    outcome = wait(handle.get_result_async())
    assert outcome.status == GoalStatus.STATUS_SUCCEEDED
    assert feedback[0].feedback.current_pose.pose.position.x == 3.0
    assert feedback[0].feedback.number_of_recoveries == 2


def test_abort_carries_nav2_error_code(client: ActionClient) -> None:
    handle = wait(client.send_goal_async(goal("abort")))
    outcome = wait(handle.get_result_async())
    assert outcome.status == GoalStatus.STATUS_ABORTED
    assert outcome.result.error_code == NavigateToPose.Result.TIMEOUT
    assert outcome.result.error_msg == "navigation timed out"


def test_cancel_reaches_the_server(client: ActionClient) -> None:
    feedback = threading.Event()
    handle = wait(client.send_goal_async(goal("run"), feedback_callback=lambda _m: feedback.set()))
    assert feedback.wait(TIMEOUT_S)
    cancel = wait(handle.cancel_goal_async())
    assert len(cancel.goals_canceling) == 1
    outcome = wait(handle.get_result_async())
    assert outcome.status == GoalStatus.STATUS_CANCELED
