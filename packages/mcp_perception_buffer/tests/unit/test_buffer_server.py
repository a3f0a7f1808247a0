"""The perception tools through the SDK's in-memory MCP client, with the buffer written
directly (no ROS) and the VisionTasks port faked."""

import asyncio
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from mcp_perception_buffer.composition import PerceptionApp, build_app, event_sink
from mcp_perception_buffer.config import PerceptionConfig
from mcp_perception_buffer.events import LoggingEventSink, PosterEventSink, RecordingEventSink
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver
from robot_stack_testing.kit.tool_calls import tool_answer
from robot_stack_testing.ports import free_tcp_port
from robot_stack_testing.ros.fake_vision import FakeVisionTasks

DET = {
    "label": "mug",
    "score": 0.9,
    "kind": "object",
    "box": {"x": 1, "y": 1, "width": 2, "height": 2},
    "point": {"x": 2.0, "y": 2.0},
    "extra": {},
}


@pytest.fixture
def tasks() -> FakeVisionTasks:
    return FakeVisionTasks()


@pytest.fixture
def sink() -> RecordingEventSink:
    return RecordingEventSink()


@pytest.fixture
def app(tasks: FakeVisionTasks, sink: RecordingEventSink) -> PerceptionApp:
    config = PerceptionConfig(stale_after_s=10.0, max_wait_s=2.0, watch_poll_s=0.05)
    return build_app(config, vision_tasks=tasks, sink=sink, follow_topics=False)


async def test_the_server_exposes_the_perception_and_task_tools(app: PerceptionApp) -> None:
    async with Client(app.server) as client:
        names = {t.name for t in (await client.list_tools()).tools}
    assert names == {
        "what_do_you_see",
        "get_latest",
        "get_history",
        "wait_for_result",
        "list_buffers",
        "get_health",
        "get_task",
        "cancel_task",
        "list_tasks",
    }
    assert app.server.name == "perception"


async def test_reads_return_stamp_age_and_stale_and_mask_refs(app: PerceptionApp) -> None:
    now = time.time()
    app.buffer.add_result("find_object", now - 1.0, [DET])
    app.buffer.add_output("find_object", "found", True, now - 1.0)
    async with Client(app.server) as client:
        latest = await tool_answer(client, "get_latest", {"skill": "find_object"})
        assert latest["stale"] is False
        assert 0.0 <= latest["age_s"] < 60
        assert latest["detections"][0]["mask_ref"]["topic"] == "/vision/find_object/detections"
        assert latest["outputs"]["found"]["value"] is True
        history = await tool_answer(client, "get_history", {"skill": "find_object", "seconds": 30})
        assert len(history["results"]) == 1
        assert history["outputs"]["found"][0]["value"] is True
        seen = await tool_answer(client, "what_do_you_see")
        assert seen["mode"] == "warm"
        buffers = await tool_answer(client, "list_buffers")
        assert buffers["buffers"][0]["skill"] == "find_object"
        assert buffers["stale"] is False
        unknown = await tool_answer(client, "get_latest", {"skill": "nope"})
        assert unknown["_error"]["error"] == "unknown_skill"
        assert "wait_for_result" in unknown["_error"]["detail"]
        bad = await tool_answer(client, "get_history", {"skill": "find_object", "seconds": 0})
        assert bad["_error"]["error"] == "invalid_seconds"


async def test_what_do_you_see_when_cold_says_how_to_get_a_fresh_view(app: PerceptionApp) -> None:
    async with Client(app.server) as client:
        seen = await tool_answer(client, "what_do_you_see")
    assert seen["mode"] == "cold"
    assert "instantiate_skill" in seen["hint"]


async def test_wait_for_result_blocks_until_a_result_arrives_from_another_thread(
    app: PerceptionApp,
) -> None:
    await app.perception.start()
    try:
        stamp = time.time()
        timer = threading.Timer(0.3, lambda: app.buffer.add_result("once", stamp, [DET]))
        timer.start()
        async with Client(app.server) as client:
            got = await tool_answer(client, "wait_for_result", {"skill": "once", "timeout_s": 10})
            assert got["detections"][0]["label"] == "mug"
            assert got["stamp"] == pytest.approx(stamp)
            newer = await tool_answer(
                client, "wait_for_result", {"skill": "once", "timeout_s": 0.3, "after_stamp": stamp}
            )
            assert newer["_error"]["error"] == "timeout"
        timer.join()
    finally:
        await app.perception.close()


async def test_watcher_tasks_are_listed_fetched_and_cancelled(
    app: PerceptionApp, tasks: FakeVisionTasks, sink: RecordingEventSink
) -> None:
    await tasks.create(
        {
            "name": "door",
            "mode": "describe",
            "outputs": [{"name": "open", "type": "boolean"}],
            "watch": {"output": "open", "equals": True},
        }
    )
    await app.perception.start()
    try:
        async with Client(app.server) as client:
            await app.perception.sync_watchers()
            listed = await tool_answer(client, "list_tasks", {"states": ["running"]})
            assert [t["task_id"] for t in listed["tasks"]] == ["watch-door"]
            task = await tool_answer(client, "get_task", {"task_id": "watch-door"})
            assert task["state"] == "running"
            assert task["server"] == "perception"
            app.buffer.add_output("door", "open", True, time.time())
            for _ in range(100):
                if sink.events:
                    break
                await asyncio.sleep(0.02)
            assert len(sink.events) == 1
            fired = await tool_answer(client, "get_task", {"task_id": "watch-door"})
            assert fired["fired"] == 1
            assert fired["last_fired_at"] == fired["fired_at"][0]
            cancelled = await tool_answer(client, "cancel_task", {"task_id": "watch-door"})
            assert cancelled["state"] == "cancelled"
            assert cancelled["skill_stopped"] is True
            assert "door" not in tasks.skills
            await app.perception.sync_watchers()
            for _ in range(100):
                if len(sink.events) >= 2:
                    break
                await asyncio.sleep(0.02)
            assert [e[2] for e in sink.events] == ["watch_event", "task_failed"]
            again = await tool_answer(client, "cancel_task", {"task_id": "watch-door"})
            assert again["skill_stopped"] is False
            missing = await tool_answer(client, "get_task", {"task_id": "watch-x"})
            assert missing["_error"]["error"] == "unknown_task"
            missing = await tool_answer(client, "cancel_task", {"task_id": "watch-x"})
            assert missing["_error"]["error"] == "unknown_task"
            assert (await tool_answer(client, "list_tasks"))["tasks"][0]["state"] == "cancelled"
    finally:
        await app.perception.close()


async def test_a_cancel_whose_skill_cannot_be_stopped_still_disarms_and_says_why(
    app: PerceptionApp, tasks: FakeVisionTasks, sink: RecordingEventSink
) -> None:
    await tasks.create(
        {
            "name": "gone",
            "mode": "describe",
            "outputs": [{"name": "open", "type": "boolean"}],
            "watch": {"output": "open", "equals": True},
        }
    )
    await app.perception.sync_watchers()
    del tasks.skills["gone"]  # deleted behind the buffer's back, before its next poll
    async with Client(app.server) as client:
        answer = await tool_answer(client, "cancel_task", {"task_id": "watch-gone"})
    assert answer["state"] == "cancelled"
    assert answer["skill_stopped"] is False
    assert answer["skill_stop_error"] == "unknown_skill"


async def test_a_failing_vision_node_does_not_break_the_watch_poll(
    app: PerceptionApp, tasks: FakeVisionTasks
) -> None:
    from robot_ros_bridge import ServiceUnavailableError

    tasks.fail_with = ServiceUnavailableError("no server for /vision_node/list_vision_tasks")
    await app.perception.sync_watchers()  # logged, not raised
    async with Client(app.server) as client:
        answer = await tool_answer(client, "cancel_task", {"task_id": "watch-a"})
        assert answer["_error"]["error"] == "unknown_task"


def test_the_process_runs_the_service_on_its_own_loop_thread(
    tasks: FakeVisionTasks, sink: RecordingEventSink
) -> None:
    app = build_app(PerceptionConfig(), vision_tasks=tasks, sink=sink, follow_topics=False)
    app.start_background()
    try:

        async def ask() -> Any:
            async with Client(app.server) as client:
                return await tool_answer(client, "list_tasks")

        assert asyncio.run(ask()) == {"tasks": []}
    finally:
        app.close()


def test_config_from_env_requires_a_secret_with_an_events_url(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="RVC_EVENT_SECRET"):
        PerceptionConfig.from_env({"RVC_EVENTS_URL": "http://127.0.0.1:8000/api/agent/events"})
    config = PerceptionConfig.from_env(
        {
            "RVC_EVENTS_URL": "http://127.0.0.1:8000/api/agent/events",
            "RVC_EVENT_SECRET": "s3cret",
            "PERCEPTION_OUTBOX_PATH": str(tmp_path / "o.sqlite3"),
            "PERCEPTION_BUFFER_MAX_COUNT": "7",
        }
    )
    assert config.max_count == 7
    assert "s3cret" not in repr(config)
    assert isinstance(event_sink(config), PosterEventSink)
    assert isinstance(event_sink(PerceptionConfig()), LoggingEventSink)


async def test_health_shows_that_the_brain_refuses_our_events_and_they_wait(
    tasks: FakeVisionTasks, tmp_path: Path
) -> None:
    receiver = RecordingReceiver({"perception": "the-brain-has-another-secret-0123456789"})
    async with ReceiverServer(receiver, free_tcp_port()) as brain:
        sink = PosterEventSink(
            brain.url, "our-secret-0123456789-0123456789", tmp_path / "o.sqlite3", "perception"
        )
        app = build_app(PerceptionConfig(), vision_tasks=tasks, sink=sink, follow_topics=False)
        await app.perception.start()
        try:
            await tasks.create(
                {
                    "name": "door",
                    "mode": "describe",
                    "outputs": [{"name": "open", "type": "boolean"}],
                    "watch": {"output": "open", "equals": True},
                }
            )
            await app.perception.sync_watchers()
            app.buffer.add_output("door", "open", True, time.time())
            await async_wait_until(lambda: receiver.rejections, 10.0, "a refused post")
            async with Client(app.server) as client:
                health = await tool_answer(client, "get_health")
        finally:
            await app.perception.close()
    assert health["status"] == "degraded"
    assert health["events"]["status"] == "refused"
    assert health["events"]["last_refusal"]["status"] == 401
    assert health["events"]["pending"] == 1
    assert health["watchers_running"] == 1


async def test_health_without_a_brain_says_events_are_not_posted() -> None:
    app_sinkless = build_app(
        PerceptionConfig(), vision_tasks=FakeVisionTasks(), follow_topics=False
    )
    await app_sinkless.perception.start()
    try:
        async with Client(app_sinkless.server) as client:
            health = await tool_answer(client, "get_health")
    finally:
        await app_sinkless.perception.close()
    assert health["status"] == "ok"
    assert health["events"]["status"] == "not_posting"


def test_the_outbox_defaults_to_the_per_user_data_dir_not_the_working_directory() -> None:
    path = PerceptionConfig().outbox_path
    assert path.is_absolute()
    assert "mcp-perception-buffer" in path.parts
