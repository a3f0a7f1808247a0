"""The arm under the brain's supervision (issues 27, 28), as composed for a robot: the kit's
Supervision is the motion gate, the ``supervise`` tool renews it, and the watchdog ends a
running pick when the lease latches or lapses. The arm is the fake at the port."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest
from mcp import Client

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_manipulation.arm.fake import FakeArm, FakeArmGoal
from robot_mcp_manipulation.composition import ManipulationApp, build_app
from robot_mcp_manipulation.config import load_settings
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.tool_calls import tool_answer

REF = {"topic": "/vision/find_object/detections", "stamp": 1_700_000_000.25, "index": 0}
PICK = {"label": "mug", "mask_ref": REF}


@pytest.fixture
async def app(tmp_path: Path) -> AsyncIterator[ManipulationApp]:
    settings = load_settings({"MANIP_OUTBOX": str(tmp_path / "outbox.sqlite3")})
    app = build_app(settings, arm=FakeArm(), events=FakeEventSink())
    async with app.running():
        yield app


def lease(latched: bool, ttl_s: float = 2.0) -> dict[str, object]:
    return {"holder": "brain-test", "latched": latched, "ttl_s": ttl_s}


async def test_supervision_is_required_by_default_and_the_lease_tool_is_served(
    app: ManipulationApp,
) -> None:
    async with Client(app.server) as client:
        names = {t.name for t in (await client.list_tools()).tools}
        assert "supervise" in names
        unsupervised = await tool_answer(client, "pick", PICK)
        assert unsupervised["_error"]["error"] == "NOT_SUPERVISED"
        await tool_answer(client, "supervise", lease(latched=False))
        started = await tool_answer(client, "pick", PICK)
        assert started["state"] == "running"


async def test_a_latched_lease_refuses_the_pick_and_cancels_the_running_one(
    app: ManipulationApp,
) -> None:
    arm = app.arm
    assert isinstance(arm, FakeArm)
    async with Client(app.server) as client:
        await tool_answer(client, "supervise", lease(latched=False))
        running = await tool_answer(client, "pick", PICK)
        await tool_answer(client, "supervise", lease(latched=True))
        await async_wait_until(lambda: arm.goals[-1].cancel_requests > 0, 5.0, "the cancel")
        await async_wait_until(lambda: not app.manipulator.moving, 5.0, "the pick ended")
        ended = await tool_answer(client, "get_task", {"task_id": running["task_id"]})
        assert ended["state"] == "cancelled"
        refused = await tool_answer(client, "pick", PICK)
        assert refused["_error"]["error"] == "SAFETY_STOP_LATCHED"
        assert (await tool_answer(client, "stop_manipulation"))["stopped"] is True  # never gated


async def test_a_pick_the_stops_cancel_all_ended_first_is_told_as_cancelled_by_the_stop(
    app: ManipulationApp,
) -> None:
    """The latch's cancel-all can reach the arm before the watchdog's own cancel: the pick
    ended because of the stop, never "the arm stopped on its own (e.g. an emergency stop)"."""
    arm = app.arm
    assert isinstance(arm, FakeArm)
    assert app.supervision is not None
    async with Client(app.server) as client:
        await tool_answer(client, "supervise", lease(latched=False))
        running = await tool_answer(client, "pick", PICK)
        goal = arm.goals[-1]
        assert isinstance(goal, FakeArmGoal)
        goal.canceled_by_another_client()
        app.supervision.renew("brain-test", 2.0, latched=True)
        await async_wait_until(lambda: not app.manipulator.moving, 5.0, "the pick ended")
        ended = await tool_answer(client, "get_task", {"task_id": running["task_id"]})
        assert ended["state"] == "cancelled", ended
        assert ended["error"]["error_code"] == "CANCELLED", ended


async def test_a_lapsed_lease_cancels_the_running_pick(app: ManipulationApp) -> None:
    arm = app.arm
    assert isinstance(arm, FakeArm)
    async with Client(app.server) as client:
        await tool_answer(client, "supervise", lease(latched=False, ttl_s=0.3))
        await tool_answer(client, "pick", PICK)
        await async_wait_until(lambda: arm.goals[-1].cancel_requests > 0, 5.0, "the cancel")
        assert app.supervision is not None
        assert app.supervision.locked()
