"""ActionGoals against a real rclpy action server (NavigateToPose from interfaces/nav2_msgs, on a
second bridge's node): send with feedback, the status → result mapping, cancel, cancel-all, the
three ways a goal does not run, and a goal accepted after we stopped waiting."""

import asyncio
import threading
import time
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from nav2_msgs.action import NavigateToPose
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup

from robot_ros_bridge import RosBridge
from robot_ros_bridge.action_goal import ActionGoal, ActionGoals, ActionUnavailableError

pytestmark = pytest.mark.ros


def _name(prefix: str) -> str:
    return f"/{prefix}_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def bridges() -> Iterator[tuple[RosBridge, RosBridge]]:
    with RosBridge("goal_client") as client, RosBridge("goal_server", num_threads=4) as server:
        yield client, server


class Server:
    """A NavigateToPose server whose behaviour each test sets: ``ending`` (succeed | abort |
    hold until canceled), ``accept``, ``answer_after`` (an event the goal answer waits for)."""

    def __init__(self, bridge: RosBridge, name: str, ending: str = "succeed") -> None:
        self.ending = ending
        self.accept = True
        self.answer_after: threading.Event | None = None
        self.cancel_requested = threading.Event()
        self.executing = threading.Event()
        self.server = ActionServer(
            bridge.node,
            NavigateToPose,
            name,
            self._execute,
            goal_callback=self._goal,
            cancel_callback=self._cancel,
            callback_group=ReentrantCallbackGroup(),
        )

    def _goal(self, request: Any) -> GoalResponse:
        if self.answer_after is not None:
            self.answer_after.wait(10.0)
        return GoalResponse.ACCEPT if self.accept else GoalResponse.REJECT

    def _cancel(self, handle: Any) -> CancelResponse:
        self.cancel_requested.set()
        return CancelResponse.ACCEPT

    def _execute(self, goal: Any) -> Any:
        self.executing.set()
        feedback = NavigateToPose.Feedback()
        feedback.distance_remaining = 2.5
        goal.publish_feedback(feedback)
        result = NavigateToPose.Result()
        if self.ending == "hold":
            deadline = time.monotonic() + 10.0
            while not goal.is_cancel_requested and time.monotonic() < deadline:
                time.sleep(0.01)
            goal.canceled()
            return result
        result.error_code = 0 if self.ending == "succeed" else 104
        result.error_msg = "done" if self.ending == "succeed" else "stuck"
        goal.succeed() if self.ending == "succeed" else goal.abort()
        return result


async def test_a_goal_reports_its_feedback_on_the_loop_and_ends_succeeded(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, server_bridge = bridges
    name = _name("goal")
    Server(server_bridge, name)
    goals = ActionGoals(client_bridge, NavigateToPose, name)
    loop_thread = threading.get_ident()
    seen: list[tuple[float, int]] = []

    goal = await goals.send(
        NavigateToPose.Goal(),
        lambda fb: seen.append((fb.distance_remaining, threading.get_ident())),
        10.0,
    )
    ended = await goal.result()

    assert ended.status == "succeeded"
    assert ended.result.error_msg == "done"
    await asyncio.sleep(0)  # the feedback was queued on the loop before the result
    assert seen == [(2.5, loop_thread)]


async def test_an_aborted_goal_carries_the_servers_result(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, server_bridge = bridges
    name = _name("abort")
    Server(server_bridge, name, ending="abort")
    goal = await ActionGoals(client_bridge, NavigateToPose, name).send(
        NavigateToPose.Goal(), lambda fb: None, 10.0
    )
    ended = await goal.result()
    assert (ended.status, ended.result.error_code, ended.result.error_msg) == (
        "aborted",
        104,
        "stuck",
    )


async def running_goal(
    bridges: tuple[RosBridge, RosBridge], prefix: str
) -> tuple[str, ActionGoals, ActionGoal]:
    """A goal the server runs until it is canceled: the action's name, its client, the goal."""
    client_bridge, server_bridge = bridges
    name = _name(prefix)
    server = Server(server_bridge, name, ending="hold")
    goals = ActionGoals(client_bridge, NavigateToPose, name)
    goal = await goals.send(NavigateToPose.Goal(), lambda fb: None, 10.0)
    assert await asyncio.to_thread(server.executing.wait, 10.0)
    return name, goals, goal


async def test_a_canceled_goal_ends_canceled_and_the_goal_was_ours(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    _, goals, goal = await running_goal(bridges, "cancel")

    assert await goal.cancel(5.0)
    ended = await goal.result()

    assert ended.status == "canceled"
    assert goals.sent(goal.goal_id)
    assert not goals.sent(uuid.uuid4().bytes)


async def test_cancel_all_reaches_a_goal_another_client_sent(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    name, _, goal = await running_goal(bridges, "all")

    canceling = await ActionGoals(bridges[0], NavigateToPose, name).cancel_all(5.0)

    assert canceling == 1
    assert (await goal.result()).status == "canceled"


async def test_no_server_is_absent_and_a_rejected_goal_is_rejected(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, server_bridge = bridges
    nobody = ActionGoals(client_bridge, NavigateToPose, _name("nobody"))
    with pytest.raises(ActionUnavailableError) as absent:
        await nobody.send(NavigateToPose.Goal(), lambda fb: None, 0.3)
    assert absent.value.reason == "absent"
    assert await nobody.cancel_all(0.3) is None
    assert not nobody.cancel_all_now()

    name = _name("reject")
    Server(server_bridge, name).accept = False
    with pytest.raises(ActionUnavailableError) as rejected:
        await ActionGoals(client_bridge, NavigateToPose, name).send(
            NavigateToPose.Goal(), lambda fb: None, 10.0
        )
    assert rejected.value.reason == "rejected"


async def test_a_goal_accepted_after_we_stopped_waiting_is_canceled_at_once(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, server_bridge = bridges
    name = _name("late")
    server = Server(server_bridge, name, ending="hold")
    goals = ActionGoals(client_bridge, NavigateToPose, name)
    await client_bridge.wait_for_server(goals._client, 10.0)
    server.answer_after = threading.Event()

    with pytest.raises(ActionUnavailableError) as silent:
        await goals.send(NavigateToPose.Goal(), lambda fb: None, 0.5)
    assert silent.value.reason == "silent"
    server.answer_after.set()  # the server accepts it now: nobody waits for this goal

    assert await asyncio.to_thread(server.cancel_requested.wait, 10.0)
