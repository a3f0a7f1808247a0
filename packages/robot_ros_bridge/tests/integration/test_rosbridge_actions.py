"""RosBridge action clients: readiness of an action server and rclpy futures on the event loop
(the NavigateToPose action from interfaces/nav2_msgs, served by a second bridge's node)."""

import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from nav2_msgs.action import NavigateToPose
from rclpy.action.server import ActionServer

from robot_ros_bridge import (
    BridgeClosedError,
    RosBridge,
    ServiceTimeoutError,
    ServiceUnavailableError,
)

pytestmark = pytest.mark.ros


def _name(prefix: str) -> str:
    return f"/{prefix}_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def bridges() -> Iterator[tuple[RosBridge, RosBridge]]:
    with RosBridge("action_client") as client, RosBridge("action_server") as server:
        yield client, server


def serve(bridge: RosBridge, name: str) -> ActionServer:
    def execute(goal: Any) -> Any:
        goal.succeed()
        result = NavigateToPose.Result()
        result.error_msg = "done"
        return result

    return ActionServer(bridge.node, NavigateToPose, name, execute)


async def test_a_goal_round_trips_once_the_server_is_ready(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, server_bridge = bridges
    name = _name("navigate")
    serve(server_bridge, name)
    client = client_bridge.create_action_client(NavigateToPose, name)
    await client_bridge.wait_for_server(client, 10.0)
    handle = await client_bridge.await_future(client.send_goal_async(NavigateToPose.Goal()), 10.0)
    assert handle.accepted
    response = await client_bridge.await_future(handle.get_result_async(), None)
    assert response.result.error_msg == "done"


async def test_no_server_is_unavailable_after_the_timeout(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    client_bridge, _ = bridges
    client = client_bridge.create_action_client(NavigateToPose, _name("nobody"))
    with pytest.raises(ServiceUnavailableError, match="no server"):
        await client_bridge.wait_for_server(client, 0.3)


async def test_a_future_that_never_completes_times_out(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    from rclpy.task import Future

    client_bridge, _ = bridges
    with pytest.raises(ServiceTimeoutError):
        await client_bridge.await_future(Future(), 0.05)
    failed: Future[Any] = Future()
    failed.set_exception(RuntimeError("boom"))
    with pytest.raises(RuntimeError, match="boom"):
        await client_bridge.await_future(failed, 1.0)


async def test_a_closed_bridge_refuses_to_wait() -> None:
    bridge = RosBridge("closing").start()
    client = bridge.create_action_client(NavigateToPose, _name("closed"))
    bridge.close()
    with pytest.raises(BridgeClosedError):
        await bridge.wait_for_server(client, 1.0)
