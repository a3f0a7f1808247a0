"""Every tool the six MCP servers publish has honest annotations and a decision in the brain's
shipped policy (issue 21): the live tool lists, read through the SDK's client from each server
built as shipped (fakes only below their ports), leave no tool without a decision."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer

from mcp_perception_buffer.composition import build_app as build_perception
from mcp_perception_buffer.config import PerceptionConfig
from mcp_perception_buffer.events import RecordingEventSink
from mcp_skill_control.composition import build_app as build_skill_control
from mcp_skill_control.config import SkillControlConfig
from robot_mcp_episodic.composition import build_app as build_episodic
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.task_events.fake import FakeEventSink as FakeArmEvents
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.fake import FakeArm
from robot_mcp_manipulation.manipulator import Manipulator
from robot_mcp_manipulation.tools import build_mcp_server as build_manipulation
from robot_mcp_memory.composition import build_memory
from robot_mcp_memory.config import MemoryConfig
from robot_mcp_memory.tools import build_server as build_memory_server
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.tools import build_mcp_server as build_navigation
from robot_stack_testing.ros.fake_vision import FakeVisionTasks
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.settings import CONFIG_DIR

MOTION_SERVERS = {"navigation", "manipulation"}  # config/tools/mcp.yaml: motion: true
MAP = {"start": "dock", "locations": {"dock": {"x": 0, "y": 0}}, "speed_mps": 2.0}


@pytest.fixture
async def live_tools(tmp_path: Path) -> AsyncIterator[dict[str, dict[str, Any] | None]]:
    navigator = Navigator(
        parse_map(MAP), FakeMotionBase(), FakeEventSink(), TaskTable(), supervision=Supervision()
    )
    arm_supervision = Supervision()  # as composed for a robot: the gate and the lease tool
    manipulator = Manipulator(FakeArm(), FakeArmEvents(), TaskTable(), gate=arm_supervision)
    memory = build_memory(MemoryConfig(db_path=tmp_path / "m.sqlite3", robot_id="r1"))
    episodic = build_episodic(
        EpisodicConfig(data_dir=tmp_path / "episodic", record_raw=False), record_ros=False
    )
    servers: dict[str, MCPServer] = {
        "navigation": build_navigation(navigator),
        "manipulation": build_manipulation(manipulator, supervision=arm_supervision),
        "memory": build_memory_server(memory),
        "skill_control": build_skill_control(SkillControlConfig(), tasks=FakeVisionTasks()).server,
        "perception": build_perception(
            PerceptionConfig(),
            vision_tasks=FakeVisionTasks(),
            sink=RecordingEventSink(),
            follow_topics=False,
        ).server,
        "episodic": episodic.server,
    }
    tools: dict[str, dict[str, Any] | None] = {}
    for name, server in servers.items():
        async with Client(server) as client:
            for tool in (await client.list_tools()).tools:
                hints = tool.annotations
                tools[f"{name}.{tool.name}"] = (
                    hints.model_dump(by_alias=True, exclude_none=True) if hints else None
                )
    yield tools
    await navigator.close()
    await manipulator.close()
    episodic.close()


async def test_every_live_tool_of_the_six_servers_has_annotations_and_a_decision(
    live_tools: dict[str, dict[str, Any] | None],
) -> None:
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    assert len(live_tools) >= 43
    undecided = [
        name for name in live_tools if (rule := policy.rule(name)) is None or rule.decision is None
    ]
    assert undecided == []
    unannotated = [name for name, hints in live_tools.items() if not hints]
    assert unannotated == []
    for name, hints in live_tools.items():
        assert hints is not None
        assert "readOnlyHint" in hints, name
        if not hints["readOnlyHint"]:
            assert "destructiveHint" in hints, name  # never left to the MCP default


async def test_the_annotations_alone_would_ask_before_any_motion_or_free_configuration(
    live_tools: dict[str, dict[str, Any] | None],
) -> None:
    """Without the policy file's entries, the defaults from the annotations still ask."""
    empty = ToolPolicy.load(CONFIG_DIR / "policy.yaml").defaults_only()
    decisions = {
        name: empty.decide(name, {}, hints, name.split(".")[0] in MOTION_SERVERS).action
        for name, hints in live_tools.items()
    }
    assert decisions["navigation.navigate_to"] == "confirm"
    assert decisions["skill_control.instantiate_raw_skill"] == "confirm"
    # a motion server's own annotations never allow anything: the policy file does (issue 27)
    assert decisions["navigation.get_pose"] == "confirm"
    for arm in ("pick", "place", "release", "get_held"):
        assert decisions[f"manipulation.{arm}"] == "confirm"  # the policy file allows get_held
    assert decisions["perception.what_do_you_see"] == "allow"
    assert decisions["memory.save_process"] == "allow"
    assert decisions["episodic.last_seen"] == "allow"
    assert decisions["episodic.record_note"] == "allow"
    assert decisions["episodic.forget"] == "confirm"
    # stopping is never asked: the guard passes cancel_task and the stop tool ungated
    assert all(action != "deny" for action in decisions.values())


async def test_the_shipped_policy_lists_no_tool_the_servers_do_not_have(
    live_tools: dict[str, dict[str, Any] | None],
) -> None:
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    assert sorted(policy.named_tools() - set(live_tools)) == []
