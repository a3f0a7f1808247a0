"""The MCP tools over the Manipulator with the fake arm: TaskInfo at once, one terminal event,
named failures with suggestions, one motion at a time, the stop never gated, the motion gate."""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.fake import FakeArm, FakeArmGoal
from robot_mcp_manipulation.arm.port import DetectionTarget, Held
from robot_mcp_manipulation.manipulator import Manipulator, ManipulatorSettings
from robot_mcp_manipulation.tools import build_mcp_server
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.tool_calls import tool_answer

REF = {
    "topic": "/vision/find_object/detections",
    "stamp": 1_700_000_000.25,
    "index": 1,
    "url": None,
}


@dataclass
class Latch:
    code: str = "SAFETY_STOP_LATCHED"
    detail: str = "a software stop is latched"


class Gate:
    def __init__(self) -> None:
        self.latched = False

    def refusal(self) -> Latch | None:
        return Latch() if self.latched else None


@dataclass
class Rig:
    arm: FakeArm
    events: FakeEventSink
    gate: Gate
    manipulator: Manipulator
    server: MCPServer


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    arm, events, gate = FakeArm(), FakeEventSink(), Gate()
    settings = ManipulatorSettings(server_timeout_s=0.2, cancel_timeout_s=1.0, task_timeout_s=5.0)
    manipulator = Manipulator(arm, events, TaskTable("manipulation"), settings, gate)
    yield Rig(arm, events, gate, manipulator, build_mcp_server(manipulator))
    await manipulator.close()


def goal(rig: Rig) -> FakeArmGoal:
    return rig.arm.goals[-1]


async def terminal(rig: Rig, task_id: str) -> Any:
    await async_wait_until(
        lambda: any(
            e.type in ("task_done", "task_failed")
            for e in rig.events.events
            if e.task_id == task_id
        ),
        5.0,
        "the terminal event",
    )
    return next(
        e
        for e in rig.events.events
        if e.task_id == task_id and e.type in ("task_done", "task_failed")
    )


async def test_the_server_offers_pick_place_release_held_stop_and_the_task_tools(rig: Rig) -> None:
    async with Client(rig.server) as client:
        tools = {t.name: t for t in (await client.list_tools()).tools}
    assert set(tools) == {
        "pick",
        "place",
        "release",
        "get_held",
        "stop_manipulation",
        "get_task",
        "cancel_task",
        "list_tasks",
    }
    for name in ("pick", "place", "release"):
        annotations = tools[name].annotations
        assert annotations is not None
        assert annotations.destructive_hint is True
        assert annotations.read_only_hint is False
    assert tools["get_held"].annotations.read_only_hint is True  # type: ignore[union-attr]
    stop = tools["stop_manipulation"].annotations
    assert stop is not None
    assert stop.idempotent_hint is True
    assert stop.destructive_hint is False
    assert "mask_ref" in json.dumps(tools["pick"].input_schema)


async def test_pick_sends_the_detection_reference_and_ends_with_what_is_held(rig: Rig) -> None:
    async with Client(rig.server) as client:
        info = await tool_answer(client, "pick", {"label": "yellow package", "mask_ref": REF})
        assert info["state"] == "running"
        assert info["task_id"].startswith("manip-")
        assert info["tool"] == "pick"
        assert info["label"] == "yellow package"
        sent = goal(rig)
        assert sent.target is not None
        assert (sent.target.topic, sent.target.stamp_s, sent.target.index) == (
            REF["topic"],
            REF["stamp"],
            1,
        )
        sent.feedback("grasping", 0.5)
        held = Held(True, "yellow package", 1_700_000_001.0)
        rig.arm.publish_held(held)
        sent.succeed(held)
        done = await terminal(rig, info["task_id"])
        assert done.type == "task_done"
        assert done.payload["held"] == {
            "holding": True,
            "label": "yellow package",
            "since": 1_700_000_001.0,
        }
        assert rig.events.types(info["task_id"]) == ["progress", "task_done"]
        now = await tool_answer(client, "get_held")
        assert now["known"]
        assert now["holding"]
        assert now["label"] == "yellow package"
        task = await tool_answer(client, "get_task", {"task_id": info["task_id"]})
        assert task["state"] == "succeeded"


@pytest.mark.parametrize(
    ("code", "named", "recoverable"),
    [
        (1, "MANIPULATION_ERROR", True),
        (2, "NOT_VISIBLE", True),
        (3, "DETECTION_STALE", True),
        (4, "OUT_OF_REACH", False),
        (5, "GRASP_FAILED", True),
        (6, "ALREADY_HOLDING", True),
        (7, "ARM_NOT_READY", True),
        (99, "MANIPULATION_ERROR", True),
    ],
)
async def test_every_pick_error_code_becomes_a_named_failure(
    rig: Rig, code: int, named: str, recoverable: bool
) -> None:
    info = await rig.manipulator.pick(DetectionTarget(REF["topic"], 1.0, 1, "yellow package"))
    goal(rig).abort(code, "the robot says why")
    failed = await terminal(rig, info.task_id)
    assert failed.type == "task_failed"
    assert failed.payload["error_code"] == named
    assert failed.payload["recoverable"] is recoverable
    assert failed.payload["suggestions"]
    assert "the robot says why" in failed.payload["message"]
    assert rig.manipulator.get_task(info.task_id).state == "failed"


@pytest.mark.parametrize(
    ("code", "named"),
    [(2, "NOTHING_HELD"), (3, "NO_SURFACE"), (4, "PLACE_FAILED"), (7, "ARM_NOT_READY")],
)
async def test_every_place_error_code_becomes_a_named_failure(
    rig: Rig, code: int, named: str
) -> None:
    info = await rig.manipulator.place()
    goal(rig).abort(code)
    failed = await terminal(rig, info.task_id)
    assert failed.payload["error_code"] == named


async def test_one_motion_at_a_time_and_the_stop_cancels_it(rig: Rig) -> None:
    async with Client(rig.server) as client:
        first = await tool_answer(client, "place")
        busy = await tool_answer(client, "release")
        assert busy["_error"]["error"] == "MANIPULATION_BUSY"
        assert first["task_id"] in busy["_error"]["detail"]
        stopped = await tool_answer(client, "stop_manipulation")
        assert stopped["cancelled_task"]["state"] == "cancelled"
        failed = await terminal(rig, first["task_id"])
        assert failed.payload["error_code"] == "CANCELLED"
        assert failed.payload["recoverable"]
        assert goal(rig).cancel_requests == 1
        nothing = await tool_answer(client, "stop_manipulation")
        assert nothing["cancelled_task"] is None


async def test_cancel_task_ends_a_running_pick_and_leaves_a_finished_one(rig: Rig) -> None:
    async with Client(rig.server) as client:
        info = await tool_answer(client, "pick", {"label": "mug", "mask_ref": REF})
        goal(rig).feedback("approaching", 0.25)
        cancelled = await tool_answer(client, "cancel_task", {"task_id": info["task_id"]})
        assert cancelled["state"] == "cancelled"
        again = await tool_answer(client, "cancel_task", {"task_id": info["task_id"]})
        assert again["state"] == "cancelled"
        assert rig.events.types(info["task_id"])[-1] == "task_failed"
        unknown = await tool_answer(client, "get_task", {"task_id": "manip-x"})
        assert unknown["_error"]["error"] == "UNKNOWN_TASK"


async def test_a_latched_gate_refuses_motion_but_never_the_stop(rig: Rig) -> None:
    rig.gate.latched = True
    async with Client(rig.server) as client:
        refused = await tool_answer(client, "pick", {"label": "mug", "mask_ref": REF})
        assert refused["_error"]["error"] == "SAFETY_STOP_LATCHED"
        assert not rig.arm.goals  # nothing was sent to the arm
        stopped = await tool_answer(client, "stop_manipulation")
        assert stopped["stopped"] is True


async def test_a_stop_latched_while_the_arm_takes_the_goal_cancels_it_at_once(rig: Rig) -> None:
    original = rig.arm.send_place

    async def latch_then_send(*args: Any) -> Any:
        sent = await original(*args)
        rig.gate.latched = True
        return sent

    rig.arm.send_place = latch_then_send  # type: ignore[method-assign]
    info = await rig.manipulator.place()
    failed = await terminal(rig, info.task_id)
    assert failed.payload["error_code"] == "CANCELLED"
    assert "SAFETY_STOP_LATCHED" in failed.payload["message"]


async def test_an_absent_arm_is_a_clean_error_and_no_task(rig: Rig) -> None:
    rig.arm.available = False
    async with Client(rig.server) as client:
        refused = await tool_answer(client, "place")
        assert refused["_error"]["error"] == "ARM_UNAVAILABLE"
        assert (await tool_answer(client, "list_tasks"))["tasks"] == []
        rig.arm.available = True
        rig.arm.reject_next = True
        assert (await tool_answer(client, "place"))["_error"]["error"] == "ARM_UNAVAILABLE"
        held = await tool_answer(client, "get_held")
        assert held["known"] is False
        assert held["busy"] is False


async def test_a_bad_mask_ref_is_refused_before_the_arm(rig: Rig) -> None:
    async with Client(rig.server) as client:
        result = await client.call_tool(
            "pick", {"label": "mug", "mask_ref": {"topic": "/camera/image_raw", "stamp": 1.0}}
        )
    assert result.is_error
    assert not rig.arm.goals


async def test_a_lost_result_and_a_hung_arm_end_the_task_honestly(rig: Rig) -> None:
    info = await rig.manipulator.place()
    goal(rig).lose(RuntimeError("result lost"))
    lost = await terminal(rig, info.task_id)
    assert lost.payload["error_code"] == "ARM_ERROR"
    assert not lost.payload["recoverable"]
    rig.manipulator._settings = ManipulatorSettings(task_timeout_s=0.1, cancel_timeout_s=1.0)
    slow = await rig.manipulator.place()
    timed_out = await terminal(rig, slow.task_id)
    assert timed_out.payload["error_code"] == "MANIPULATION_TIMEOUT"
    assert goal(rig).cancel_requests == 1


async def test_an_arm_that_stops_on_its_own_is_not_called_a_cancel(rig: Rig) -> None:
    info = await rig.manipulator.place()
    await goal(rig).cancel(1.0)  # the robot's own stop, not ours
    stopped = await terminal(rig, info.task_id)
    assert stopped.payload["error_code"] == "ARM_STOPPED"
    assert rig.manipulator.get_task(info.task_id).state == "failed"
