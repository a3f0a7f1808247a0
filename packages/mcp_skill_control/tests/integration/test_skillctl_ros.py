"""skill_control's tools over MCP (in-memory client) against a fake VisionTask service node
in real rclpy (spec 001 §7 items 2-3)."""

import asyncio
import json
import time
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from mcp import Client

from mcp_skill_control.composition import SkillControlApp, build_app
from mcp_skill_control.config import SkillControlConfig
from robot_ros_bridge import RosBridge
from robot_stack_testing import async_wait_until
from robot_stack_testing.ros.fake_vision import FakeVisionNode

pytestmark = pytest.mark.ros


async def call(client: Client, tool: str, args: dict[str, Any] | None = None) -> Any:
    result = await client.call_tool(tool, args or {})
    payload = json.loads(result.content[0].text)  # type: ignore[union-attr]
    return {"_error": payload} if result.is_error else payload


@pytest.fixture
def vision() -> Iterator[FakeVisionNode]:
    with FakeVisionNode(f"vision_{uuid.uuid4().hex[:8]}") as node:
        yield node


@pytest.fixture
def bridge() -> Iterator[RosBridge]:
    with RosBridge(f"skillctl_{uuid.uuid4().hex[:8]}") as b:
        yield b


@pytest.fixture
def app(vision: FakeVisionNode, bridge: RosBridge) -> SkillControlApp:
    config = SkillControlConfig(
        vision_node_name=vision.name, call_timeout_s=15.0, wait_for_service_s=4.0
    )
    return build_app(config, bridge=bridge)


async def test_instantiate_creates_the_filled_skill_and_its_topic_appears(
    app: SkillControlApp, vision: FakeVisionNode, bridge: RosBridge
) -> None:
    async with Client(app.server) as client:
        await _instantiate_then_stop(client, vision, bridge)


async def _instantiate_then_stop(client: Client, vision: FakeVisionNode, bridge: RosBridge) -> None:
    made = await call(
        client,
        "instantiate_skill",
        {"template": "find_object", "params": {"query": "scissors on top"}},
    )
    assert made["topic"] == "/vision/find_object/detections"
    create = [data for service, data in vision.requests if service == "create"]
    assert create == [
        {
            "mode": "ground_and_segment",
            "grounding": "the scissors on top",
            "segment": True,
            "outputs": [
                {
                    "name": "found",
                    "type": "boolean",
                    "description": "whether the scissors on top is visible",
                }
            ],
            "name": "find_object",
            "description": "Locate and segment a specific object the user names.",
        }
    ]
    await async_wait_until(
        lambda: made["topic"] in bridge.topic_names_and_types(), 10.0, "the topic in the graph"
    )
    running = await call(client, "list_running_skills")
    assert running["skills"][0]["skill_id"] == "find_object"
    assert running["skills"][0]["semantic_topics"] == ["/vision/find_object/found"]

    stopped = await call(client, "stop_skill", {"skill_id": "find_object"})
    assert stopped == {"skill_id": "find_object", "stopped": True}
    assert ("manage", {"task_name": "find_object", "action": "delete"}) in vision.requests
    await async_wait_until(
        lambda: made["topic"] not in bridge.topic_names_and_types(), 10.0, "the topic to go"
    )


async def test_a_refusal_of_the_vision_node_is_a_clean_error_carrying_its_code(
    app: SkillControlApp, vision: FakeVisionNode
) -> None:
    async with Client(app.server) as client:
        await _refusal(client, vision)


async def _refusal(client: Client, vision: FakeVisionNode) -> None:
    vision.fail_next["create"] = ("grounder_unavailable", "the grounder is not configured")
    refused = await call(client, "instantiate_skill", {"template": "segment_all", "params": {}})
    assert refused["_error"] == {
        "error": "grounder_unavailable",
        "detail": "the grounder is not configured",
    }
    ok = await call(client, "instantiate_skill", {"template": "segment_all", "params": {}})
    assert ok["skill_id"] == "segment_all"


async def test_a_slow_vision_node_times_out_cleanly_and_the_server_keeps_working(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    config = SkillControlConfig(
        vision_node_name=vision.name, call_timeout_s=0.5, wait_for_service_s=0.5
    )
    app = build_app(config, bridge=bridge)
    async with Client(app.server) as client:
        await async_wait_until(
            lambda: f"/{vision.name}/list_vision_tasks" in bridge.service_names_and_types(),
            10.0,
            "the service in the graph",
        )
        vision.reply_delay_s = 1.5
        slow = await call(client, "list_running_skills")
        assert slow["_error"]["error"] == "service_timeout"
        vision.reply_delay_s = 0.0
        assert await call(client, "list_running_skills") == {"skills": []}


async def test_every_tool_fails_cleanly_and_in_time_when_the_vision_node_is_absent(
    bridge: RosBridge,
) -> None:
    config = SkillControlConfig(
        vision_node_name=f"absent_{uuid.uuid4().hex[:6]}",
        call_timeout_s=2.0,
        wait_for_service_s=0.5,
    )
    app = build_app(config, bridge=bridge)
    calls: list[tuple[str, dict[str, Any]]] = [
        ("list_running_skills", {}),
        ("instantiate_skill", {"template": "describe_scene", "params": {}}),
        ("instantiate_raw_skill", {"skill": {"name": "a", "mode": "describe"}}),
        ("prewarm_skill", {"template": "find_object", "params": {"query": "cup"}}),
        ("stop_skill", {"skill_id": "a"}),
        ("set_skill_enabled", {"skill_id": "a", "enabled": True}),
    ]
    async with Client(app.server) as client:
        assert (await call(client, "list_skill_templates"))["templates"]
        for tool, args in calls:
            started = time.monotonic()
            answer = await asyncio.wait_for(call(client, tool, args), timeout=10.0)
            assert answer["_error"]["error"] == "service_unavailable", tool
            assert (
                "list_vision_tasks" in answer["_error"]["detail"]
                or "manage_vision_task" in answer["_error"]["detail"]
            )
            assert time.monotonic() - started < 10.0


async def _service_in_graph(bridge: RosBridge, vision: FakeVisionNode) -> None:
    await async_wait_until(
        lambda: f"/{vision.name}/create_vision_task" in bridge.service_names_and_types(),
        10.0,
        "the service in the graph",
    )


async def test_a_create_answered_after_the_client_timeout_is_adopted(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    config = SkillControlConfig(
        vision_node_name=vision.name, call_timeout_s=0.5, wait_for_service_s=0.5, reconcile_s=10
    )
    app = build_app(config, bridge=bridge)
    vision.reply_delays["create"] = 1.5  # the node creates the skill after the client gave up
    try:
        async with Client(app.server) as client:
            await _service_in_graph(bridge, vision)
            made = await call(client, "instantiate_skill", {"template": "segment_all"})
            running = await call(client, "list_running_skills")
    finally:
        await app.control.close()
    assert "_error" not in made, made
    assert made["skill_id"] == "segment_all"
    assert [s["skill_id"] for s in running["skills"]] == ["segment_all"]
    assert [s for s, _ in vision.requests].count("create") == 1  # adopted, not created twice


async def test_a_create_that_never_shows_up_in_time_is_an_error_and_leaves_no_orphan(
    vision: FakeVisionNode, bridge: RosBridge
) -> None:
    config = SkillControlConfig(
        vision_node_name=vision.name,
        call_timeout_s=0.5,
        wait_for_service_s=0.5,
        reconcile_s=0.3,
        orphan_sweep_s=30,
    )
    app = build_app(config, bridge=bridge)
    vision.reply_delays["create"] = 2.5  # lands after the reconcile window
    try:
        async with Client(app.server) as client:
            await _service_in_graph(bridge, vision)
            failed = await call(client, "instantiate_skill", {"template": "segment_all"})
            assert failed["_error"]["error"] == "service_timeout"
            assert "not running" in failed["_error"]["detail"]
            await async_wait_until(
                lambda: (
                    ("manage", {"task_name": "segment_all", "action": "delete"}) in vision.requests
                ),
                20.0,
                "the late skill removed",
            )
    finally:
        await app.control.close()
    assert vision.skills() == {}
