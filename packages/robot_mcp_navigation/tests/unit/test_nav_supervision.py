"""The navigation server under supervision (issue 27): the brain's lease and latch decide
whether anything moves, whoever asks; a lapse or a latch cancels what runs."""

import asyncio
import json
from collections.abc import AsyncIterator
from dataclasses import dataclass

import pytest
from mcp import Client

from robot_mcp_kit.supervision import NOT_SUPERVISED, SAFETY_STOP_LATCHED, Supervision
from robot_mcp_kit.supervision_tools import watch_supervision
from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.errors import MotionRefusedError
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.motion.base import DriveFailure
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.tools import build_mcp_server
from robot_stack_testing import async_wait_until

MAP = {
    "name": "test",
    "start": "dock",
    "speed_mps": 1.0,
    "locations": {"dock": {"x": 0, "y": 0}, "kitchen": {"x": 100, "y": 0}},
}


class Clock:
    def __init__(self) -> None:
        self.now = 50.0

    def __call__(self) -> float:
        return self.now


@dataclass
class Rig:
    clock: Clock
    supervision: Supervision
    base: FakeMotionBase
    events: FakeEventSink
    navigator: Navigator


class AbortingBase(FakeMotionBase):
    """Takes the cancel but ends the goal its own way, as robot-sim does when its supervisor
    lock engages (Nav2's progress checker: FAILED_TO_MAKE_PROGRESS)."""

    async def stop(self) -> None:
        self.stop_calls += 1
        self.fail(DriveFailure("ROBOT_STUCK", "Failed to make progress"))


@pytest.fixture
def base() -> FakeMotionBase:
    return FakeMotionBase()


@pytest.fixture
async def rig(base: FakeMotionBase) -> AsyncIterator[Rig]:
    clock = Clock()
    supervision = Supervision(clock=clock)
    events = FakeEventSink()
    navigator = Navigator(parse_map(MAP), base, events, TaskTable(), supervision=supervision)
    watchdog = asyncio.create_task(
        watch_supervision(supervision, navigator.stop, lambda: navigator.moving, 0.005)
    )
    yield Rig(clock, supervision, base, events, navigator)
    watchdog.cancel()
    await navigator.close()


async def test_a_server_without_a_lease_refuses_to_drive_and_nothing_moves(rig: Rig) -> None:
    with pytest.raises(MotionRefusedError) as refused:
        await rig.navigator.navigate_to("kitchen")

    assert refused.value.code == NOT_SUPERVISED
    assert rig.base.goals == []


async def test_a_latched_lease_refuses_to_drive_and_nothing_moves(rig: Rig) -> None:
    rig.supervision.renew("brain", 1.0, latched=True, reason="operator pressed stop")

    with pytest.raises(MotionRefusedError) as refused:
        await rig.navigator.navigate_to("kitchen")

    assert refused.value.code == SAFETY_STOP_LATCHED
    assert rig.base.goals == []


async def test_a_lapsed_lease_cancels_the_running_drive(rig: Rig) -> None:
    rig.supervision.renew("brain", 1.0, latched=False)
    info = await rig.navigator.navigate_to("kitchen")

    rig.clock.now += 1.5  # the brain stopped renewing

    await async_wait_until(
        lambda: rig.navigator.get_task(info.task_id).state == "cancelled", 5, "cancelled"
    )
    failed = rig.events.events[-1]
    assert failed.type == "task_failed"
    assert "supervision was lost" in failed.payload["message"]
    assert rig.base.stop_calls >= 1


async def test_a_latch_cancels_the_running_drive_and_clearing_resumes_nothing(rig: Rig) -> None:
    rig.supervision.renew("brain", 1.0, latched=False)
    info = await rig.navigator.navigate_to("kitchen")

    rig.supervision.renew("brain", 1.0, latched=True)
    await async_wait_until(
        lambda: rig.navigator.get_task(info.task_id).state == "cancelled", 5, "cancelled"
    )
    rig.supervision.renew("brain", 1.0, latched=False)

    assert "software stop was latched" in rig.events.events[-1].payload["message"]
    assert len(rig.base.goals) == 1
    assert rig.navigator.pose()["moving"] is False


@pytest.mark.parametrize("base", [AbortingBase()])
async def test_a_drive_the_base_aborts_after_our_stop_counts_as_cancelled(rig: Rig) -> None:
    rig.supervision.renew("brain", 1.0, latched=False)
    info = await rig.navigator.navigate_to("kitchen")
    await async_wait_until(lambda: rig.base.driving, 5, "the base driving")

    final = await rig.navigator.stop(reason="the software stop was latched")

    assert final is not None
    assert final.state == "cancelled"
    assert rig.navigator.get_task(info.task_id).error["error_code"] == "CANCELLED"  # type: ignore[index]


async def test_another_client_cannot_drive_a_latched_server_over_mcp(rig: Rig) -> None:
    server = build_mcp_server(rig.navigator)

    async with Client(server) as brain, Client(server) as other:
        await brain.call_tool("supervise", {"holder": "brain", "latched": True, "ttl_s": 1.0})
        refused = await other.call_tool("navigate_to", {"location": "kitchen"})

    assert refused.is_error
    assert json.loads(refused.content[0].text)["error"] == SAFETY_STOP_LATCHED  # type: ignore[union-attr]
    assert rig.base.goals == []


async def test_a_drive_the_lock_ended_before_the_watchdog_looked_is_cancelled_not_stuck() -> None:
    """The lock publisher says locked the moment the lease runs out and robot-sim aborts its
    goal at once; the watchdog may look only afterwards. The drive ended for supervision."""
    clock = Clock()
    supervision = Supervision(clock=clock)
    base = FakeMotionBase()
    navigator = Navigator(
        parse_map(MAP), base, FakeEventSink(), TaskTable(), supervision=supervision
    )
    supervision.renew("brain", 1.0, latched=False)
    info = await navigator.navigate_to("kitchen")
    await async_wait_until(lambda: base.driving, 5, "the base driving")

    clock.now += 1.5  # lapsed; no watchdog runs here
    base.fail(DriveFailure("ROBOT_STUCK", "Failed to make progress"))
    await async_wait_until(lambda: not navigator.moving, 5, "the drive over")

    task = navigator.get_task(info.task_id)
    assert task.state == "cancelled"
    assert "supervision was lost" in task.error["message"]  # type: ignore[index]
    await navigator.close()
