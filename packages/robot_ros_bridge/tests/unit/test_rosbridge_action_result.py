"""ActionGoal.result without a ROS graph: the status mapping and a result that never came."""

from types import SimpleNamespace
from typing import Any

import pytest

from robot_ros_bridge.action_goal import ActionGoal

pytestmark = pytest.mark.ros


class PreparedBridge:
    """Answers every awaited future with ``answer`` (raised when it is an exception)."""

    def __init__(self, answer: Any) -> None:
        self.answer = answer

    async def await_future(self, future: Any, timeout_s: float | None) -> Any:
        if isinstance(self.answer, BaseException):
            raise self.answer
        return self.answer


def goal_of(answer: Any) -> ActionGoal:
    handle = SimpleNamespace(get_result_async=lambda: object())
    return ActionGoal(PreparedBridge(answer), handle)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("code", "status"), [(4, "succeeded"), (5, "canceled"), (6, "aborted"), (2, "unknown")]
)
async def test_the_action_status_maps_to_a_named_status(code: int, status: str) -> None:
    result = SimpleNamespace(error_code=7)
    ended = await goal_of(SimpleNamespace(status=code, result=result)).result()
    assert (ended.status, ended.result) == (status, result)


async def test_a_result_that_never_came_is_unknown_with_the_reason() -> None:
    ended = await goal_of(RuntimeError("the client was destroyed")).result()
    assert (ended.status, ended.result, ended.error) == (
        "unknown",
        None,
        "the client was destroyed",
    )
