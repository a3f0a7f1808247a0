"""RosBridge against real rclpy service nodes, in this process and in another one."""

import asyncio
import sys
import uuid
from collections.abc import Iterator

import pytest

from robot_ros_bridge import (
    BridgeClosedError,
    RemoteError,
    RosBridge,
    ServiceTimeoutError,
    ServiceUnavailableError,
)
from robot_ros_bridge.vision_tasks import RosVisionTasks
from robot_stack_testing import async_wait_until
from robot_stack_testing.ros.fake_vision import FakeVisionNode

pytestmark = pytest.mark.ros


def _unique(prefix: str) -> str:
    return f"{prefix}_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def bridge() -> Iterator[RosBridge]:
    with RosBridge(_unique("client")) as b:
        yield b


@pytest.fixture
def vision() -> Iterator[FakeVisionNode]:
    with FakeVisionNode(_unique("vision")) as node:
        yield node


async def test_a_call_to_an_in_process_service_returns_its_response(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    created = await tasks.create({"name": "mug", "mode": "describe"})
    assert created["name"] == "mug"
    assert created["topics"]["detections"] == "/vision/mug/detections"
    assert [s["name"] for s in await tasks.list()] == ["mug"]
    await tasks.manage("mug", "disable")
    assert vision.enabled("mug") is False
    await tasks.manage("mug", "delete")
    assert await tasks.list() == []


async def test_a_failed_reply_is_raised_as_a_remote_error_with_the_nodes_code(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    with pytest.raises(RemoteError) as info:
        await tasks.manage("nope", "delete")
    assert info.value.code == "unknown_skill"


async def test_a_missing_service_fails_fast_with_service_unavailable(bridge: RosBridge) -> None:
    tasks = RosVisionTasks(bridge, _unique("absent"), timeout_s=30.0, wait_for_service_s=0.3)
    with pytest.raises(ServiceUnavailableError) as info:
        await asyncio.wait_for(tasks.list(), timeout=5.0)
    assert "list_vision_tasks" in info.value.detail
    assert info.value.code == "service_unavailable"


async def test_a_slow_service_times_out_and_its_request_is_dropped(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.list()  # discovered
    vision.reply_delay_s = 1.5
    slow = RosVisionTasks(bridge, vision.name, timeout_s=0.3, wait_for_service_s=5.0)
    with pytest.raises(ServiceTimeoutError):
        await slow.list()
    client = slow._clients["list"]
    assert client._pending_requests == {}
    vision.reply_delay_s = 0.0
    assert await tasks.list() == []


async def test_a_cancelled_call_drops_its_pending_request(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.list()
    vision.reply_delay_s = 1.0
    call = asyncio.create_task(tasks.list())
    await async_wait_until(lambda: len(vision.requests) >= 2, 5.0, "the request to arrive")
    call.cancel()
    with pytest.raises(asyncio.CancelledError):
        await call
    assert tasks._clients["list"]._pending_requests == {}


async def test_graph_helpers_see_a_new_skills_topics(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.create(
        {"name": "cup", "mode": "describe", "outputs": [{"name": "found", "type": "boolean"}]}
    )
    await async_wait_until(
        lambda: "/vision/cup/found" in bridge.topic_names_and_types(),
        10.0,
        "the output topic in the graph",
    )
    topics = bridge.topic_names_and_types()
    assert topics["/vision/cup/detections_meta"] == [
        "ros2_vision_interfaces/msg/VisionDetectionArray"
    ]
    assert f"/{vision.name}/create_vision_task" in bridge.service_names_and_types()
    assert bridge.publisher_count("/vision/cup/found") == 1


async def test_a_subscription_delivers_messages_on_an_executor_thread(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    from ros2_vision_interfaces.msg import StampedString

    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.create(
        {"name": "door", "mode": "describe", "outputs": [{"name": "open", "type": "boolean"}]}
    )
    got: list[str] = []
    sub = bridge.create_subscription(
        StampedString, "/vision/door/open", lambda m: got.append(m.data)
    )

    def published() -> bool:
        vision.publish_output("door", "open", True)
        return bool(got)

    await async_wait_until(published, 10.0, "a message", interval_s=0.1)
    assert got[0] == "true"
    bridge.destroy_subscription(sub)


async def test_a_raw_subscription_delivers_the_serialized_bytes(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    from rclpy.serialization import deserialize_message
    from ros2_vision_interfaces.msg import StampedString

    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.create(
        {"name": "lid", "mode": "describe", "outputs": [{"name": "open", "type": "boolean"}]}
    )
    got: list[bytes] = []
    bridge.create_subscription(StampedString, "/vision/lid/open", got.append, raw=True)

    def published() -> bool:
        vision.publish_output("lid", "open", False)
        return bool(got)

    await async_wait_until(published, 10.0, "a raw message", interval_s=0.1)
    assert isinstance(got[0], bytes)
    assert deserialize_message(got[0], StampedString).data == "false"


async def test_a_single_threaded_bridge_calls_services_and_delivers_raw_messages(
    vision: FakeVisionNode,
) -> None:
    from rclpy.executors import SingleThreadedExecutor
    from ros2_vision_interfaces.msg import StampedString

    with RosBridge(_unique("single"), executor="single_threaded") as single:
        assert isinstance(single._executor, SingleThreadedExecutor)
        tasks = RosVisionTasks(single, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
        await tasks.create(
            {"name": "tap", "mode": "describe", "outputs": [{"name": "on", "type": "boolean"}]}
        )
        got: list[bytes] = []
        single.create_subscription(StampedString, "/vision/tap/on", got.append, raw=True)

        def published() -> bool:
            vision.publish_output("tap", "on", True)
            return bool(got)

        await async_wait_until(published, 10.0, "a raw message", interval_s=0.1)
        assert isinstance(got[0], bytes)


def test_an_unknown_executor_kind_is_refused() -> None:
    with pytest.raises(ValueError, match="single_threaded"):
        RosBridge("never_started", executor="events")  # type: ignore[arg-type]


async def test_a_closed_bridge_refuses_calls_cleanly(vision: FakeVisionNode) -> None:
    b = RosBridge(_unique("closing")).start()
    tasks = RosVisionTasks(b, vision.name)
    b.close()
    b.close()  # idempotent
    assert b.closed
    with pytest.raises(BridgeClosedError):
        await tasks.list()
    with pytest.raises(BridgeClosedError):
        _ = b.node
    with pytest.raises(BridgeClosedError):
        b.start()


@pytest.mark.parametrize("kind", ["multi_threaded", "single_threaded"])
def test_close_ends_the_spin_thread_before_the_executor_is_shut_down(kind: str) -> None:
    # rclpy's Executor.shutdown destroys its guard condition at once, under a spin thread
    # still waiting on it (a segfault on stop in a busy CI run): the thread must end first.
    b = RosBridge(_unique("closing"), executor=kind).start()  # type: ignore[arg-type]
    thread, executor = b._thread, b._executor
    assert thread is not None
    assert executor is not None
    assert thread.is_alive()
    alive_at_shutdown: list[bool] = []
    shutdown = executor.shutdown

    def recording_shutdown(*args: object, **kwargs: object) -> bool:
        alive_at_shutdown.append(thread.is_alive())
        return bool(shutdown(*args, **kwargs))  # type: ignore[arg-type]

    executor.shutdown = recording_shutdown  # type: ignore[method-assign]
    b.close()
    assert alive_at_shutdown == [False]


def test_an_unstarted_bridge_has_no_node() -> None:
    with pytest.raises(BridgeClosedError):
        _ = RosBridge("never_started").node


async def test_a_service_in_another_process_answers_and_survives_a_restart(
    bridge: RosBridge, launcher: "object"
) -> None:
    from robot_stack_testing import ProcessLauncher

    assert isinstance(launcher, ProcessLauncher)
    name = _unique("remote_vision")
    argv = [sys.executable, "-m", "robot_stack_testing.ros.fake_vision", "--name", name]
    proc = launcher.start("fake-vision", argv)
    # the process imports robot_stack_testing first: give its start a generous deadline
    tasks = RosVisionTasks(bridge, name, timeout_s=10.0, wait_for_service_s=60.0)
    created = await tasks.create({"name": "box", "mode": "region"})
    assert created["name"] == "box"
    launcher.stop(proc)
    quick = RosVisionTasks(bridge, name, timeout_s=2.0, wait_for_service_s=0.5)
    await async_wait_until(
        lambda: not quick._clients["list"].service_is_ready(), 10.0, "the service to vanish"
    )
    with pytest.raises(ServiceUnavailableError):
        await quick.list()
    launcher.start("fake-vision-again", argv)
    assert await tasks.list() == []  # same client objects, new server process


async def test_the_first_call_to_a_server_that_just_appeared_is_answered_exactly_once() -> None:
    for _ in range(3):
        with RosBridge(_unique("fresh_client"), discovery_settle_s=0.5) as fresh:
            tasks = RosVisionTasks(fresh, _unique("fresh_vision"), timeout_s=10.0)
            with FakeVisionNode(tasks._clients["list"].service_name.split("/")[1]) as node:
                created = await tasks.create({"name": "mug", "mode": "describe"})
                assert created["name"] == "mug"
                assert [key for key, _ in node.requests] == ["create"]


async def test_a_request_is_held_back_until_the_service_has_settled(
    vision: FakeVisionNode,
) -> None:
    with RosBridge(_unique("settling"), discovery_settle_s=3600.0) as settling:
        tasks = RosVisionTasks(settling, vision.name, timeout_s=6.0, wait_for_service_s=5.0)
        call = asyncio.create_task(tasks.list())
        await async_wait_until(
            lambda: tasks._clients["list"].service_is_ready(), 5.0, "the service to be ready"
        )
        assert vision.requests == []  # ready, but not settled: nothing sent yet
        assert await call == []  # sent after half the timeout at the latest
        assert [key for key, _ in vision.requests] == ["list"]


async def test_a_callback_that_raises_does_not_stop_the_bridge(
    bridge: RosBridge, vision: FakeVisionNode
) -> None:
    from ros2_vision_interfaces.msg import StampedString

    tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
    await tasks.create(
        {"name": "lamp", "mode": "describe", "outputs": [{"name": "on", "type": "boolean"}]}
    )
    calls: list[str] = []

    def broken(msg: StampedString) -> None:
        calls.append(msg.data)
        raise RuntimeError("a buggy callback")

    bridge.create_subscription(StampedString, "/vision/lamp/on", broken)

    def delivered() -> bool:
        vision.publish_output("lamp", "on", True)
        return bool(calls)

    await async_wait_until(delivered, 20.0, "the broken callback to run", interval_s=0.1)
    assert [s["name"] for s in await tasks.list()] == ["lamp"]  # still spinning


class _AnsweredAtOnce:
    """A client whose reply arrives the moment the request is sent: the answer is handed to
    the event loop in the same tick as a cancel that lands right after the send."""

    service_name = "/instant/answer"

    def __init__(self) -> None:
        self.dropped: list[object] = []

    def service_is_ready(self) -> bool:
        return True

    def call_async(self, request: object) -> object:
        class Done:
            def add_done_callback(self, callback: object) -> None:
                callback(self)  # type: ignore[operator]

            def exception(self) -> None:
                return None

            def result(self) -> str:
                return "answer"

        return Done()

    def remove_pending_request(self, future: object) -> None:
        self.dropped.append(future)


async def test_a_cancel_that_lands_as_the_answer_arrives_is_not_swallowed() -> None:
    # asyncio.wait_for on 3.11 returns the answer here and eats the cancel, so a polling loop
    # calling the service never ends and whoever awaits its cancellation hangs (a CI hang).
    with RosBridge(_unique("cancel"), discovery_settle_s=0.0) as bridge:
        call = asyncio.create_task(bridge.call_service(_AnsweredAtOnce(), object(), 5.0))
        await asyncio.sleep(0)  # the call sends; its answer is queued on the loop
        call.cancel()
        with pytest.raises(asyncio.CancelledError):
            await call
