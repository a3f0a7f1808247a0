import asyncio
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import pytest

from robot_mcp_kit.models import EventType
from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.errors import NavigationBusyError, UnknownLocationError, UnknownTaskError
from robot_mcp_navigation.map import NavMap, parse_map
from robot_mcp_navigation.motion.base import (
    DriveFailure,
    DriveGoal,
    DriveProgress,
    DriveResult,
    Pose,
    ProgressCallback,
)
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator, NavigatorSettings
from robot_mcp_navigation.triggers import DistanceBelow, EtaBelow
from robot_stack_testing import async_wait_until

MAP = {
    "name": "test",
    "start": "dock",
    "speed_mps": 1.0,
    "locations": {
        "dock": {"x": 0, "y": 0},
        "kitchen": {"x": 100, "y": 0, "description": "coffee"},
        "mailroom": {"x": 0, "y": 50, "aliases": ["post room"]},
    },
}


@dataclass
class Rig:
    nav_map: NavMap
    base: FakeMotionBase
    events: FakeEventSink
    navigator: Navigator


def make_rig(**settings: float) -> Rig:
    nav_map = parse_map(MAP)
    base = FakeMotionBase(speed_mps=1.0)
    events = FakeEventSink()
    counter = iter(range(1, 1000))
    navigator = Navigator(
        nav_map,
        base,
        events,
        TaskTable(),
        NavigatorSettings(**settings),
        task_ids=lambda: f"nav-{next(counter)}",
    )
    return Rig(nav_map, base, events, navigator)


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    rig = make_rig()
    yield rig
    await rig.navigator.close()


async def until_driving(rig: Rig) -> None:
    await async_wait_until(lambda: rig.base.driving, 5, "the base to start driving", 0.001)


async def until_finished(rig: Rig, task_id: str) -> None:
    await async_wait_until(
        lambda: rig.navigator.get_task(task_id).state != "running", 5, "the task to end", 0.001
    )


async def test_navigate_to_returns_a_running_task_info_at_once(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("Kitchen")

    assert info.task_id == "nav-1"
    assert info.state == "running"
    assert info.est_duration_s == pytest.approx(100.0)
    assert info.model_dump()["destination"] == "kitchen"
    await until_driving(rig)
    assert rig.base.goals[-1].name == "kitchen"


async def test_an_unknown_location_is_refused_naming_the_known_ones(rig: Rig) -> None:
    with pytest.raises(UnknownLocationError, match="dock, kitchen, mailroom"):
        await rig.navigator.navigate_to("garage")

    assert rig.navigator.list_tasks() == []


async def test_a_second_navigation_while_one_runs_is_refused(rig: Rig) -> None:
    first = await rig.navigator.navigate_to("kitchen")

    with pytest.raises(NavigationBusyError, match=first.task_id):
        await rig.navigator.navigate_to("mailroom")

    assert [t.task_id for t in rig.navigator.list_tasks()] == [first.task_id]


async def test_arrival_ends_the_task_with_task_done_after_progress(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)
    await rig.base.report(remaining_m=100, elapsed_s=0)
    await rig.base.report(remaining_m=50, elapsed_s=50)

    rig.base.arrive(elapsed_s=100)
    await until_finished(rig, info.task_id)

    assert rig.events.types(info.task_id) == ["progress", "progress", "task_done"]
    done = rig.events.events[-1].payload
    assert done["destination"] == "kitchen"
    assert done["pose"]["x"] == 100
    final = rig.navigator.get_task(info.task_id)
    assert final.state == "succeeded"
    assert final.model_dump()["result"]["duration_s"] == 100
    assert rig.navigator.pose()["at_location"] == "kitchen"


async def test_progress_events_are_rate_limited_by_percent_step() -> None:
    rig = make_rig(progress_interval_s=1000.0, progress_pct_step=10.0)
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)

    for remaining in range(100, 0, -1):  # 100 reports of 1 % each
        await rig.base.report(remaining_m=remaining, elapsed_s=100 - remaining)

    pcts = [e.payload["pct"] for e in rig.events.events if e.type == "progress"]
    assert pcts == [0, 10, 20, 30, 40, 50, 60, 70, 80, 90]
    await rig.navigator.close()
    assert rig.navigator.get_task(info.task_id).state == "cancelled"


async def test_progress_events_also_come_when_enough_robot_time_passed() -> None:
    rig = make_rig(progress_interval_s=5.0, progress_pct_step=50.0)
    await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)

    for second in range(12):
        await rig.base.report(remaining_m=100 - second * 0.1, elapsed_s=second)

    elapsed = [e.payload["elapsed_s"] for e in rig.events.events if e.type == "progress"]
    assert elapsed == [0, 5, 10]
    await rig.navigator.close()


async def test_an_eta_trigger_fires_once_when_the_eta_drops_below(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen", [EtaBelow(seconds=10)])
    await until_driving(rig)

    for remaining in (30, 12, 9.5, 5, 1):
        await rig.base.report(remaining_m=remaining, elapsed_s=100 - remaining)

    fired = [e for e in rig.events.events if e.type == "trigger_fired"]
    assert len(fired) == 1
    assert fired[0].payload["trigger"] == {"type": "eta_below", "seconds": 10}
    assert fired[0].payload["eta_s"] == 9.5
    assert fired[0].task_id == info.task_id


async def test_a_distance_trigger_fires_when_close_enough(rig: Rig) -> None:
    await rig.navigator.navigate_to("kitchen", [DistanceBelow(meters=2), EtaBelow(seconds=1)])
    await until_driving(rig)

    await rig.base.report(remaining_m=1.5, elapsed_s=98)

    fired = [e.payload["trigger"]["type"] for e in rig.events.events if e.type == "trigger_fired"]
    assert fired == ["distance_below"]


async def test_a_base_failure_becomes_task_failed_with_the_failure_details(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("mailroom")
    await until_driving(rig)

    rig.base.fail(DriveFailure("DOOR_CLOSED", "The mailroom door is closed.", True, ["knock"]))
    await until_finished(rig, info.task_id)

    last = rig.events.events[-1]
    assert last.type == "task_failed"
    assert last.payload["error_code"] == "DOOR_CLOSED"
    assert last.payload["recoverable"] is True
    assert last.payload["suggestions"] == ["knock"]
    final = rig.navigator.get_task(info.task_id)
    assert final.state == "failed"
    assert final.model_dump()["error"]["error_code"] == "DOOR_CLOSED"
    assert rig.navigator.pose()["moving"] is False


async def test_stop_halts_cancels_and_silences_the_task(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen", [EtaBelow(seconds=10)])
    await until_driving(rig)
    await rig.base.report(remaining_m=80, elapsed_s=20)

    final = await rig.navigator.stop()

    assert final is not None
    assert final.state == "cancelled"
    assert rig.base.stop_calls == 1
    assert rig.events.types(info.task_id) == ["progress", "task_failed"]
    failed = rig.events.events[-1].payload
    assert failed["error_code"] == "CANCELLED"
    assert failed["state"] == "cancelled"
    assert failed["recoverable"] is True


async def test_progress_reported_after_cancellation_is_not_emitted() -> None:
    rig = make_rig()
    release = asyncio.Event()
    callbacks: list[ProgressCallback] = []

    async def stubborn_drive(goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        callbacks.append(on_progress)
        await release.wait()
        return DriveResult("stopped", rig.base.pose, 1.0)

    rig.base.drive_to = stubborn_drive  # type: ignore[method-assign]
    info = await rig.navigator.navigate_to("kitchen", [EtaBelow(seconds=1000)])
    await async_wait_until(lambda: callbacks, 5, "the drive to start", 0.001)
    stopping = asyncio.create_task(rig.navigator.stop())
    await asyncio.sleep(0)  # let stop() mark the task cancelled before the late report
    await callbacks[0](DriveProgress(Pose(1, 0), 100, 99, 99, 1))
    release.set()
    final = await asyncio.wait_for(stopping, 5)

    assert final is not None
    assert final.state == "cancelled"
    assert rig.events.types(info.task_id) == ["task_failed"]


async def test_cancel_task_cancels_the_running_navigation(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)

    final = await rig.navigator.cancel_task(info.task_id)

    assert final.state == "cancelled"
    assert rig.events.events[-1].payload["message"].endswith("where it is")
    assert "cancel_task" in rig.events.events[-1].payload["message"]


async def test_cancelling_a_finished_task_returns_it_unchanged(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)
    rig.base.arrive()
    await until_finished(rig, info.task_id)
    before = len(rig.events.events)

    final = await rig.navigator.cancel_task(info.task_id)

    assert final.state == "succeeded"
    assert len(rig.events.events) == before
    assert rig.base.stop_calls == 0


async def test_unknown_task_ids_are_reported(rig: Rig) -> None:
    with pytest.raises(UnknownTaskError, match="nav-404"):
        await rig.navigator.cancel_task("nav-404")


async def test_stop_without_a_navigation_still_halts_the_base(rig: Rig) -> None:
    assert await rig.navigator.stop() is None
    assert rig.base.stop_calls == 1


async def test_a_base_that_halts_on_its_own_fails_the_task_as_base_stopped(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)

    await rig.base.stop()  # e.g. an emergency stop button, not our request
    await until_finished(rig, info.task_id)

    assert rig.navigator.get_task(info.task_id).state == "failed"
    assert rig.events.events[-1].payload["error_code"] == "BASE_STOPPED"


async def test_a_crashing_base_fails_the_task_and_frees_the_navigator(rig: Rig) -> None:
    async def broken_drive(goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        raise RuntimeError("motor controller unreachable")

    rig.base.drive_to = broken_drive  # type: ignore[method-assign]
    info = await rig.navigator.navigate_to("kitchen")
    await until_finished(rig, info.task_id)

    assert rig.events.events[-1].payload["error_code"] == "BASE_ERROR"
    assert rig.navigator.pose()["moving"] is False


async def test_a_drive_that_takes_far_too_long_is_halted_and_failed() -> None:
    rig = make_rig(time_scale=1000.0, drive_timeout_factor=0.001, drive_timeout_margin_s=0.001)
    info = await rig.navigator.navigate_to("kitchen")

    await until_finished(rig, info.task_id)

    assert rig.navigator.get_task(info.task_id).state == "failed"
    assert rig.events.events[-1].payload["error_code"] == "NAVIGATION_TIMEOUT"
    assert rig.base.stop_calls == 1


async def test_an_event_sink_failure_does_not_break_the_navigation() -> None:
    rig = make_rig()

    async def broken_emit(
        task_id: str, tool: str, type: EventType, payload: dict[str, Any]
    ) -> None:
        raise OSError("disk full")

    rig.events.emit = broken_emit  # type: ignore[method-assign]
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)
    await rig.base.report(remaining_m=50, elapsed_s=50)
    rig.base.arrive()

    await until_finished(rig, info.task_id)
    assert rig.navigator.get_task(info.task_id).state == "succeeded"


async def test_get_task_shows_live_progress_while_running(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)
    await rig.base.report(remaining_m=25, elapsed_s=75)

    live = rig.navigator.get_task(info.task_id).model_dump()

    assert live["progress"]["pct"] == 75
    assert live["progress"]["eta_s"] == 25


async def test_pose_and_locations_describe_where_the_robot_is(rig: Rig) -> None:
    pose = rig.navigator.pose()
    listing = rig.navigator.locations()

    assert pose["at_location"] == "dock"
    assert pose["moving"] is False
    by_name = {loc["name"]: loc for loc in listing["locations"]}
    assert by_name["kitchen"]["distance_m"] == 100
    assert by_name["mailroom"]["aliases"] == ["post room"]
    assert listing["map"] == "test"


async def test_list_tasks_filters_by_state(rig: Rig) -> None:
    done = await rig.navigator.navigate_to("kitchen")
    await until_driving(rig)
    rig.base.arrive()
    await until_finished(rig, done.task_id)
    running = await rig.navigator.navigate_to("dock")

    assert [t.task_id for t in rig.navigator.list_tasks(["running"])] == [running.task_id]
    assert [t.task_id for t in rig.navigator.list_tasks(["succeeded"])] == [done.task_id]
    assert len(rig.navigator.list_tasks()) == 2
