"""A ROS callback's exception stays inside the callback (it would otherwise unwind the
executor's spin and can lose a service reply in flight)."""

from typing import Any

from robot_ros_bridge.bridge import _accepts_two, _contained


def test_a_raising_one_argument_callback_is_logged_not_raised() -> None:
    seen: list[Any] = []

    def broken(msg: Any) -> None:
        seen.append(msg)
        raise RuntimeError("a buggy callback")

    wrapped = _contained(broken, "/vision/lamp/on")
    assert wrapped("hello") is None
    assert seen == ["hello"]
    assert not _accepts_two(wrapped)


def test_a_raising_service_handler_answers_its_default_response() -> None:
    response = object()

    def handler(request: Any, reply: Any) -> Any:
        raise ValueError("cannot handle " + str(request))

    wrapped = _contained(handler, "/node/service")
    assert _accepts_two(wrapped)
    assert wrapped("req", response) is response


def test_a_working_callback_keeps_its_result() -> None:
    assert _contained(lambda request, reply: reply + 1, "/s")(0, 41) == 42
