"""The ROS adapter's bookkeeping of what is held, without a ROS graph."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from robot_mcp_manipulation.arm.port import Held

pytestmark = pytest.mark.ros


class ResultOnlyBridge:
    """Hands back a prepared action result for any awaited future."""

    def __init__(self, response: Any) -> None:
        self.response = response

    async def await_future(self, future: Any, timeout_s: float | None) -> Any:
        return self.response


async def test_a_picks_result_says_what_is_held_before_the_held_topic_does() -> None:
    from builtin_interfaces.msg import Time
    from robot_manipulation_interfaces.msg import HeldObject

    from robot_mcp_manipulation.arm.rclpy_arm import RclpyArmGoal
    from robot_ros_bridge.action_goal import ActionGoal

    held = HeldObject(holding=True, label="yellow package", since=Time(sec=12))
    response = SimpleNamespace(
        status=4,  # SUCCEEDED
        result=SimpleNamespace(error_code=0, error_msg="", held=held, placed_label=""),
    )
    handle = SimpleNamespace(get_result_async=lambda: object())
    remembered: list[Held] = []
    sent = ActionGoal(ResultOnlyBridge(response), handle)  # type: ignore[arg-type]
    goal = RclpyArmGoal(sent, remembered.append)

    outcome = await goal.outcome()

    assert outcome.status == "succeeded"
    assert remembered == [Held(True, "yellow package", 12.0)]
