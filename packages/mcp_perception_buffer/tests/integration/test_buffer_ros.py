"""The buffer against a fake vision node in real rclpy: discovery, subscriptions, drops,
recovery after a vision node restart, and signed watch events at a real HTTP receiver."""

import json
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from mcp_perception_buffer.composition import build_app
from mcp_perception_buffer.config import PerceptionConfig
from mcp_perception_buffer.events import PosterEventSink
from robot_ros_bridge import RosBridge
from robot_ros_bridge.vision_tasks import RosVisionTasks
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver
from robot_stack_testing.ros.fake_vision import FakeVisionNode

pytestmark = pytest.mark.ros

SECRET = "watch-secret"
MUG = {
    "label": "mug",
    "score": 0.8,
    "box": [10, 20, 30, 40],
    "extra": {"mask_url": "http://127.0.0.1:9112/masks/find/0.png"},
}


async def call(client: Client, tool: str, args: dict[str, Any] | None = None) -> Any:
    result = await client.call_tool(tool, args or {})
    text = result.content[0].text  # type: ignore[union-attr]
    payload = json.loads(text)
    return {"_error": payload, "_text": text} if result.is_error else {**payload, "_text": text}


def _name(prefix: str) -> str:
    return f"{prefix}_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def vision() -> Iterator[FakeVisionNode]:
    with FakeVisionNode(_name("vision")) as node:
        yield node


@pytest.fixture
def bridge() -> Iterator[RosBridge]:
    with RosBridge(_name("buffer")) as b:
        yield b


def _config(vision: FakeVisionNode, **extra: Any) -> PerceptionConfig:
    values: dict[str, Any] = {
        "vision_node_name": vision.name,
        "graph_poll_s": 0.1,
        "watch_poll_s": 0.2,
        "gone_grace_s": 0.3,
        "stale_after_s": 30.0,
    }
    return PerceptionConfig(**{**values, **extra})


async def test_a_new_skill_is_discovered_buffered_and_dropped_when_its_topics_go(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    app = build_app(_config(vision), bridge=bridge)
    tasks = RosVisionTasks(bridge, vision.name, wait_for_service_s=5.0)
    await app.perception.start()
    try:
        await tasks.create(
            {
                "name": "find",
                "mode": "ground_and_segment",
                "grounding": "mug",
                "outputs": [{"name": "found", "type": "boolean"}],
            }
        )
        async with Client(app.server) as client:
            await async_wait_until(
                lambda: (
                    "find" in app.perception.list_buffers()["following"]
                    and len(app.perception.list_buffers()["following"]) == 1
                ),
                10.0,
                "the skill to be followed",
            )

            def publish_and_check() -> bool:
                vision.publish_detections("find", [MUG])
                vision.publish_output("find", "found", True)
                snap = app.buffer.snapshot("find")
                return bool(snap and snap.results and snap.outputs.get("found"))

            await async_wait_until(publish_and_check, 10.0, "a buffered result", interval_s=0.1)
            latest = await call(client, "get_latest", {"skill": "find"})
            det = latest["detections"][0]
            assert det["label"] == "mug"
            assert det["box"] == {"x": 10, "y": 20, "width": 30, "height": 40}
            assert det["mask_ref"]["url"] == "http://127.0.0.1:9112/masks/find/0.png"
            assert det["mask_ref"]["topic"] == "/vision/find/detections"
            assert latest["outputs"]["found"]["value"] is True
            assert "mask" not in det
            assert '"data"' not in latest["_text"]
            buffers = await call(client, "list_buffers")
            assert buffers["buffers"][0]["topics"] == [
                "/vision/find/detections_meta",
                "/vision/find/found",
            ]

            await tasks.manage("find", "delete")
            await async_wait_until(
                lambda: app.buffer.snapshot("find") is None, 10.0, "the buffer to be dropped"
            )
            gone = await call(client, "get_latest", {"skill": "find"})
            assert gone["_error"]["error"] == "unknown_skill"
    finally:
        await app.perception.close()


async def test_a_stopped_skill_whose_topics_another_node_still_reads_stays_dropped(
    vision: FakeVisionNode, bridge: RosBridge, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The episodic recorder (any reader) keeps a stopped skill's topics in the graph with no
    publisher: the buffer drops the skill once and does not follow it again (it used to
    re-subscribe and drop it every grace period, for as long as the reader lived)."""
    from ros2_vision_interfaces.msg import VisionDetectionArray

    app = build_app(_config(vision), bridge=bridge)
    tasks = RosVisionTasks(bridge, vision.name, wait_for_service_s=5.0)
    following = lambda: app.perception.list_buffers()["following"]  # noqa: E731
    polls: list[list[str]] = []  # what was followed right after each graph poll
    sync_graph = app.perception.sync_graph

    async def noted_sync_graph() -> None:
        await sync_graph()
        polls.append(following())

    monkeypatch.setattr(app.perception, "sync_graph", noted_sync_graph)
    await app.perception.start()
    try:
        with RosBridge(_name("reader")) as reader:
            reader.create_subscription(
                VisionDetectionArray, "/vision/find/detections_meta", lambda _m: None
            )
            reader.create_subscription(
                VisionDetectionArray, "/vision/ghost/detections_meta", lambda _m: None
            )
            await tasks.create({"name": "find", "mode": "ground_and_segment", "grounding": "mug"})
            await async_wait_until(lambda: "find" in following(), 10.0, "the skill followed")
            await tasks.manage("find", "delete")
            await async_wait_until(lambda: "find" not in following(), 10.0, "the skill dropped")
            dropped_at = len(polls)
            await async_wait_until(  # polls 0.1 s apart: over two grace periods (0.3 s)
                lambda: len(polls) >= dropped_at + 8, 20.0, "eight more graph polls"
            )
            followed_again = [
                skill for seen in polls[dropped_at:] for skill in seen if skill in ("find", "ghost")
            ]
            assert followed_again == []
    finally:
        await app.perception.close()


async def test_wait_for_result_discovers_a_just_created_skill_and_returns_its_first_result(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    app = build_app(_config(vision, graph_poll_s=30.0), bridge=bridge)
    tasks = RosVisionTasks(bridge, vision.name, wait_for_service_s=5.0)
    await app.perception.start()
    try:
        await tasks.create({"name": "once", "mode": "region", "grounding": "shelf"})
        async with Client(app.server) as client:
            import threading

            stop = threading.Event()

            def keep_publishing() -> None:
                while not stop.wait(0.1):
                    vision.publish_detections("once", [MUG])

            publisher = threading.Thread(target=keep_publishing, daemon=True)
            publisher.start()
            try:
                got = await call(client, "wait_for_result", {"skill": "once", "timeout_s": 15})
            finally:
                stop.set()
                publisher.join(timeout=5)
            assert got["detections"][0]["label"] == "mug"
    finally:
        await app.perception.close()


async def test_the_buffer_recovers_when_the_vision_node_restarts(bridge: RosBridge) -> None:
    name = _name("restarting")
    app = build_app(
        PerceptionConfig(
            vision_node_name=name,
            graph_poll_s=0.1,
            watch_poll_s=0.2,
            gone_grace_s=0.3,
            call_timeout_s=1.0,
            wait_for_service_s=0.2,
        ),
        bridge=bridge,
    )
    await app.perception.start()
    try:
        async with Client(app.server) as client:
            cold = await call(client, "what_do_you_see")
            assert cold["mode"] == "cold"
            absent = await call(client, "cancel_task", {"task_id": "watch-x"})
            assert absent["_error"]["error"] == "unknown_task"
            for attempt in range(2):
                with FakeVisionNode(name) as vision:
                    tasks = RosVisionTasks(bridge, name, wait_for_service_s=5.0)
                    await tasks.create(
                        {
                            "name": "scene",
                            "mode": "describe",
                            "outputs": [{"name": "scene_description", "type": "text"}],
                        }
                    )

                    def warm(v: FakeVisionNode = vision, n: int = attempt) -> bool:
                        v.publish_output("scene", "scene_description", f"a desk {n}")
                        snap = app.buffer.snapshot("scene")
                        values = snap.outputs.get("scene_description") if snap else None
                        return bool(values) and values[-1].value == f"a desk {n}"  # type: ignore[index]

                    await async_wait_until(warm, 15.0, "the scene in the buffer", interval_s=0.1)
                    seen = await call(client, "what_do_you_see")
                    assert seen["scene_description"]["value"] == f"a desk {attempt}"
                await async_wait_until(
                    lambda: app.buffer.snapshot("scene") is None,
                    10.0,
                    "the buffer to drop the dead node's skill",
                )
    finally:
        await app.perception.close()


async def test_a_watcher_posts_one_signed_event_per_rising_edge_to_a_real_receiver(
    vision: FakeVisionNode, bridge: RosBridge, tcp_port: int, tmp_path: Path
) -> None:
    receiver = RecordingReceiver({"perception": SECRET})
    async with ReceiverServer(receiver, tcp_port) as server:
        sink = PosterEventSink(server.url, SECRET, tmp_path / "outbox.sqlite3", "perception")
        app = build_app(_config(vision), bridge=bridge, sink=sink)
        tasks = RosVisionTasks(bridge, vision.name, wait_for_service_s=5.0)
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
            await async_wait_until(
                lambda: app.perception._watchers.get("watch-door"), 10.0, "the watcher to arm"
            )

            async def publish(value: bool) -> None:
                before = app.buffer.seq("door")

                def landed() -> bool:
                    if app.buffer.seq("door") == before:
                        vision.publish_output("door", "open", value)
                    return app.buffer.seq("door") > before

                await async_wait_until(landed, 10.0, f"value {value} buffered", interval_s=0.1)

            await publish(False)
            await publish(True)
            await async_wait_until(lambda: len(receiver.accepted()) >= 1, 10.0, "one event")
            for _ in range(3):
                await publish(True)  # staying true posts nothing more
            await publish(False)
            assert len(receiver.accepted()) == 1
            await publish(True)
            await async_wait_until(lambda: len(receiver.accepted()) >= 2, 10.0, "second event")
            events = [d.event for d in receiver.accepted()]
            assert [(e.task_id, e.type, e.server, e.seq) for e in events] == [
                ("watch-door", "watch_event", "perception", events[0].seq),
                ("watch-door", "watch_event", "perception", events[0].seq + 1),
            ]
            assert events[0].payload["value"] is True
            assert events[0].payload["skill"] == "door"
            assert receiver.rejections == []
        finally:
            await app.perception.close()


def _gids(bridge: RosBridge, topic: str) -> set[bytes]:
    return {bytes(i.endpoint_gid) for i in bridge.node.get_publishers_info_by_topic(topic)}


async def test_a_skill_recreated_under_the_same_name_is_never_served_the_old_ones_results(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    # No help from polling or the grace period: only the read path can catch the switch.
    app = build_app(_config(vision, graph_poll_s=30.0, gone_grace_s=60.0), bridge=bridge)
    tasks = RosVisionTasks(bridge, vision.name, wait_for_service_s=5.0)
    spec = {"name": "find", "mode": "describe", "outputs": [{"name": "found", "type": "boolean"}]}
    meta = "/vision/find/detections_meta"
    await app.perception.start()
    try:
        async with Client(app.server) as client:
            await tasks.create(spec)

            def old_buffered() -> bool:
                vision.publish_detections("find", [{**MUG, "label": "old mug"}])
                vision.publish_output("find", "found", True)
                snap = app.buffer.snapshot("find")
                return bool(snap and snap.results and snap.outputs.get("found"))

            await app.perception.sync_graph()
            await async_wait_until(old_buffered, 10.0, "the old skill's results", interval_s=0.1)
            old = _gids(bridge, meta)
            assert old

            await tasks.manage("find", "delete")
            await tasks.create(spec)
            await async_wait_until(
                lambda: bool(_gids(bridge, meta)) and not (_gids(bridge, meta) & old),
                10.0,
                "the new skill's publishers to replace the old ones in the graph",
            )
            fresh = await call(client, "get_latest", {"skill": "find"})
            assert fresh["_error"]["error"] == "unknown_skill"  # nothing of the old skill
            seen = await call(client, "what_do_you_see")
            assert "old mug" not in seen["_text"]

            def new_buffered() -> bool:
                vision.publish_detections("find", [{**MUG, "label": "new box"}])
                return app.buffer.snapshot("find") is not None

            await async_wait_until(new_buffered, 10.0, "the new skill's result", interval_s=0.1)
            latest = await call(client, "get_latest", {"skill": "find"})
            assert latest["detections"][0]["label"] == "new box"
            assert "found" not in latest["outputs"]  # the old skill's value went with it
            history = await call(client, "get_history", {"skill": "find", "seconds": 60})
            assert "old mug" not in history["_text"]
    finally:
        await app.perception.close()
