"""Nav2MotionBase behind the Navigator, against the in-memory Nav2Action fake (the port)."""

import asyncio
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import pytest

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.errors import BaseUnavailableNavigationError, NavigationBusyError
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.motion.base import (
    BaseUnavailableError,
    DriveGoal,
    DriveProgress,
    MotionBusyError,
    Pose,
)
from robot_mcp_navigation.motion.nav2.base import Nav2MotionBase
from robot_mcp_navigation.motion.nav2.fake import FakeGoal, FakeNav2Action
from robot_mcp_navigation.motion.nav2.port import Nav2Goal
from robot_mcp_navigation.navigator import Navigator, NavigatorSettings
from robot_mcp_navigation.triggers import EtaBelow
from robot_stack_testing import async_wait_until

MAP = {
    "name": "test",
    "start": "dock",
    "speed_mps": 1.0,
    "locations": {
        "dock": {"x": 0, "y": 0},
        "kitchen": {"x": 10, "y": 0, "theta": 1.57},
        "mailroom": {"x": 0, "y": 20},
    },
    "failures": [
        {
            "location": "mailroom",
            "error_code": "DOOR_CLOSED",
            "message": "The mailroom door is closed.",
            "suggestions": [
                'use the east entrance (navigate_to("dock"), then navigate_to("mailroom"))'
            ],
        }
    ],
}


@dataclass
class Rig:
    action: FakeNav2Action
    base: Nav2MotionBase
    events: FakeEventSink
    navigator: Navigator


def make_rig(
    server_timeout_s: float = 0.2, cancel_timeout_s: float = 0.5, stop_timeout_s: float = 5.0
) -> Rig:
    nav_map = parse_map(MAP)
    action = FakeNav2Action()
    base = Nav2MotionBase(
        action,
        frame="map",
        speed_mps=1.0,
        initial_pose=Pose(0, 0),
        site_hints={f.location: tuple(f.suggestions) for f in nav_map.failures},
        server_timeout_s=server_timeout_s,
        cancel_timeout_s=cancel_timeout_s,
    )
    events = FakeEventSink()
    counter = iter(range(1, 1000))
    navigator = Navigator(
        nav_map,
        base,
        events,
        TaskTable(),
        NavigatorSettings(progress_interval_s=0.0, stop_timeout_s=stop_timeout_s),
        task_ids=lambda: f"nav-{next(counter)}",
    )
    return Rig(action, base, events, navigator)


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    rig = make_rig()
    yield rig
    await rig.navigator.close()


async def until_finished(rig: Rig, task_id: str) -> None:
    await async_wait_until(
        lambda: rig.navigator.get_task(task_id).state != "running", 5, "the task to end", 0.001
    )


async def until_events(rig: Rig, task_id: str, count: int) -> None:
    await async_wait_until(
        lambda: len(rig.events.types(task_id)) >= count, 5, f"{count} events", 0.001
    )


def goal(rig: Rig) -> FakeGoal:
    return rig.action.goals[-1]


async def test_the_goal_is_the_locations_pose_in_the_map_frame(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    assert info.state == "running"
    assert goal(rig).pose == Pose(10, 0, 1.57)
    assert goal(rig).frame == "map"


async def test_feedback_becomes_progress_and_triggers_then_success_is_task_done(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen", [EtaBelow(seconds=3)])
    g = goal(rig)
    g.feedback(Pose(2, 0), distance_remaining_m=8.0, eta_s=8.0, navigation_time_s=2.0)
    g.feedback(Pose(8, 0), distance_remaining_m=2.0, eta_s=2.0, navigation_time_s=8.0)
    await until_events(rig, info.task_id, 3)
    g.succeed()
    await until_finished(rig, info.task_id)
    assert rig.events.types(info.task_id) == ["progress", "trigger_fired", "progress", "task_done"]
    first = rig.events.events[0].payload
    assert first["pct"] == 20.0
    assert first["eta_s"] == 8.0
    assert first["pose"] == {"x": 2.0, "y": 0.0, "theta": 0.0}
    assert rig.navigator.get_task(info.task_id).state == "succeeded"


async def test_nav2_distance_along_the_path_never_makes_progress_negative(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    goal(rig).feedback(Pose(0, 0), distance_remaining_m=14.0, eta_s=0.0)  # path > straight line
    await until_events(rig, info.task_id, 1)
    payload = rig.events.events[0].payload
    assert payload["pct"] == 0.0
    assert payload["eta_s"] == 14.0  # Nav2 gave no estimate yet: distance / speed


async def test_pose_follows_the_feedback_while_driving_and_the_topic_otherwise(rig: Rig) -> None:
    assert rig.navigator.pose()["x"] == 0.0  # no pose message yet: the map's start
    rig.action.publish_pose(Pose(1.0, 2.0, 0.5))
    assert rig.navigator.pose() | {} == rig.navigator.pose()
    assert (rig.navigator.pose()["x"], rig.navigator.pose()["y"]) == (1.0, 2.0)
    await rig.navigator.navigate_to("kitchen")
    goal(rig).feedback(Pose(4.0, 0.0), distance_remaining_m=6.0)
    await async_wait_until(lambda: rig.navigator.pose()["x"] == 4.0, 5, "feedback pose", 0.001)
    rig.action.publish_pose(Pose(4.5, 0.1))  # newer than the feedback
    assert rig.navigator.pose()["x"] == 4.5


async def test_arrival_within_nav2_goal_tolerance_counts_as_at_the_location(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    goal(rig).succeed()
    await until_finished(rig, info.task_id)
    rig.action.publish_pose(Pose(9.8, 0.1))
    assert rig.navigator.pose()["at_location"] == "kitchen"


@pytest.mark.parametrize(
    ("nav2_code", "named", "recoverable"),
    [
        (208, "NO_PATH", True),
        (105, "ROBOT_STUCK", True),
        (9002, "LOCALIZATION_LOST", False),
        (9003, "NAVIGATION_TIMEOUT", True),
        (4242, "NAV2_ERROR", False),
    ],
)
async def test_abort_is_task_failed_with_the_named_code(
    rig: Rig, nav2_code: int, named: str, recoverable: bool
) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    goal(rig).abort(nav2_code, "planner says no")
    await until_finished(rig, info.task_id)
    assert rig.events.types(info.task_id) == ["task_failed"]
    payload = rig.events.events[-1].payload
    assert payload["error_code"] == named
    assert payload["recoverable"] is recoverable
    assert f"Nav2 error {nav2_code}: planner says no" in payload["message"]
    assert payload["suggestions"]
    assert payload["state"] == "failed"


async def test_abort_on_the_way_to_a_known_trouble_spot_suggests_the_maps_detour_first(
    rig: Rig,
) -> None:
    info = await rig.navigator.navigate_to("mailroom")
    goal(rig).abort(208, "no valid path")
    await until_finished(rig, info.task_id)
    suggestions = rig.events.events[-1].payload["suggestions"]
    assert suggestions[0].startswith("use the east entrance")
    assert len(suggestions) > 1


async def test_a_lost_robot_gets_no_detour_suggestion(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("mailroom")
    goal(rig).abort(9002, "no transform")
    await until_finished(rig, info.task_id)
    assert not any("east entrance" in s for s in rig.events.events[-1].payload["suggestions"])


async def test_stop_cancels_the_goal_and_one_cancelled_event_follows(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    g = goal(rig)
    g.feedback(Pose(2, 0), distance_remaining_m=8.0)
    await until_events(rig, info.task_id, 1)
    final = await rig.navigator.stop()
    assert g.cancel_requests == 1
    assert g.done  # the server reported CANCELED before stop returned
    assert final is not None
    assert final.state == "cancelled"
    g.feedback(Pose(3, 0), distance_remaining_m=7.0)  # late feedback is dropped
    await asyncio.sleep(0)
    assert rig.events.types(info.task_id) == ["progress", "task_failed"]
    assert rig.events.events[-1].payload["error_code"] == "CANCELLED"


async def test_a_cancel_the_server_never_confirms_returns_within_the_bound() -> None:
    rig = make_rig(cancel_timeout_s=0.2, stop_timeout_s=0.3)
    rig.action.cancel_answers = False
    info = await rig.navigator.navigate_to("kitchen")
    loop = asyncio.get_running_loop()
    started = loop.time()
    final = await rig.navigator.stop()
    assert loop.time() - started < 2.0
    assert final is not None
    assert final.state == "running"  # honest: Nav2 has not confirmed the cancel
    goal(rig).cancel_by_server()
    await until_finished(rig, info.task_id)
    assert rig.navigator.get_task(info.task_id).state == "cancelled"


async def test_cancel_by_the_server_alone_is_base_stopped(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    goal(rig).cancel_by_server()
    await until_finished(rig, info.task_id)
    assert rig.events.events[-1].payload["error_code"] == "BASE_STOPPED"


async def test_a_lost_result_fails_the_task_cleanly(rig: Rig) -> None:
    info = await rig.navigator.navigate_to("kitchen")
    goal(rig).lose(RuntimeError("result service vanished"))
    await until_finished(rig, info.task_id)
    payload = rig.events.events[-1].payload
    assert payload["error_code"] == "BASE_ERROR"
    assert "result service vanished" in payload["message"]


async def test_absent_server_is_base_unavailable_then_recovers_when_it_appears() -> None:
    rig = make_rig(server_timeout_s=0.1)
    rig.action.available = False
    with pytest.raises(BaseUnavailableNavigationError, match="no NavigateToPose server"):
        await rig.navigator.navigate_to("kitchen")
    assert rig.navigator.list_tasks() == []
    assert rig.navigator.pose()["moving"] is False
    rig.action.available = True
    info = await rig.navigator.navigate_to("kitchen")
    assert info.state == "running"
    await rig.navigator.close()


async def test_rejected_goal_is_base_unavailable_and_leaves_no_task(rig: Rig) -> None:
    rig.action.reject_next = True
    with pytest.raises(BaseUnavailableNavigationError, match="rejected"):
        await rig.navigator.navigate_to("kitchen")
    assert rig.navigator.list_tasks() == []
    assert (await rig.navigator.navigate_to("kitchen")).state == "running"


async def test_parallel_navigate_to_starts_one_goal_and_refuses_the_rest(rig: Rig) -> None:
    results = await asyncio.gather(
        *(rig.navigator.navigate_to("kitchen") for _ in range(5)), return_exceptions=True
    )
    started = [r for r in results if not isinstance(r, BaseException)]
    busy = [r for r in results if isinstance(r, NavigationBusyError)]
    assert len(started) == 1
    assert len(busy) == 4
    assert len(rig.action.goals) == 1


def hold_send_goal(
    rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> tuple[asyncio.Event, asyncio.Event]:
    """The action's ``send_goal`` says when it was entered, then waits for the release (the
    server is still deciding). Returns (entered, release)."""
    entered, release = asyncio.Event(), asyncio.Event()
    send_goal = rig.action.send_goal

    async def held(*args: Any, **kwargs: Any) -> Nav2Goal:
        entered.set()
        await release.wait()
        return await send_goal(*args, **kwargs)

    monkeypatch.setattr(rig.action, "send_goal", held)
    return entered, release


def note_base_stop(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> asyncio.Event:
    """Set once the navigator's stop has reached the base (its stop runs on in that step)."""
    reached = asyncio.Event()
    stop = rig.base.stop

    async def noted() -> None:
        reached.set()
        await stop()

    monkeypatch.setattr(rig.base, "stop", noted)
    return reached


async def test_stop_while_the_goal_is_being_accepted_cancels_it_once_accepted(
    rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> None:
    accepting, accept = hold_send_goal(rig, monkeypatch)
    stop_reached_base = note_base_stop(rig, monkeypatch)
    attempt = asyncio.create_task(rig.navigator.navigate_to("kitchen"))
    await asyncio.wait_for(accepting.wait(), 5)
    stopping = asyncio.create_task(rig.navigator.stop())
    await asyncio.wait_for(stop_reached_base.wait(), 5)
    accept.set()  # the server accepts the goal only after the stop was asked for
    await stopping
    info = await attempt
    assert goal(rig).cancel_requests == 1
    await until_finished(rig, info.task_id)
    assert rig.navigator.get_task(info.task_id).state == "cancelled"
    assert rig.events.types(info.task_id) == ["task_failed"]


async def test_stop_while_no_server_answers_leaves_no_goal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    rig = make_rig(server_timeout_s=0.3)
    rig.action.available = False
    waiting_for_server, answer = hold_send_goal(rig, monkeypatch)
    answer.set()  # the fake then waits out its 0.3 s server timeout
    attempt = asyncio.create_task(rig.navigator.navigate_to("kitchen"))
    await asyncio.wait_for(waiting_for_server.wait(), 5)
    await rig.navigator.stop()
    with pytest.raises(BaseUnavailableNavigationError):
        await attempt  # the goal never ran
    assert rig.action.goals == []


async def test_drive_timeout_cancels_the_goal_at_the_server() -> None:
    nav_map = parse_map(MAP)
    action = FakeNav2Action()
    base = Nav2MotionBase(action, frame="map", speed_mps=1.0, initial_pose=Pose(0, 0))
    events = FakeEventSink()
    navigator = Navigator(
        nav_map,
        base,
        events,
        TaskTable(),
        NavigatorSettings(drive_timeout_factor=0.0, drive_timeout_margin_s=0.05),
    )
    info = await navigator.navigate_to("kitchen")
    await until_finished(Rig(action, base, events, navigator), info.task_id)
    assert action.goals[0].cancel_requests >= 1
    assert events.events[-1].payload["error_code"] == "NAVIGATION_TIMEOUT"


async def test_the_base_refuses_a_second_drive_itself() -> None:
    action = FakeNav2Action()
    base = Nav2MotionBase(action, frame="map", speed_mps=1.0, initial_pose=Pose(0, 0))

    async def ignore(_p: DriveProgress) -> None:
        return None

    outcome = await base.start_drive(DriveGoal("a", Pose(1, 0)), ignore)
    with pytest.raises(MotionBusyError):
        await base.start_drive(DriveGoal("b", Pose(2, 0)), ignore)
    action.goals[0].succeed()
    assert (await outcome).status == "arrived"
    drive = asyncio.create_task(base.drive_to(DriveGoal("c", Pose(3, 0)), ignore))
    await async_wait_until(lambda: len(action.goals) == 2, 5, "second goal", 0.001)
    action.goals[1].succeed()
    assert (await drive).status == "arrived"
    await base.stop()  # idle: a no-op


async def test_unavailable_base_error_carries_the_detail() -> None:
    action = FakeNav2Action(available=False)
    base = Nav2MotionBase(
        action, frame="map", speed_mps=1.0, initial_pose=Pose(0, 0), server_timeout_s=0.01
    )

    async def ignore(_p: DriveProgress) -> None:
        return None

    with pytest.raises(BaseUnavailableError) as caught:
        await base.start_drive(DriveGoal("a", Pose(1, 0)), ignore)
    assert "within 0.01 s" in caught.value.detail
    assert base.driving is False


def test_bad_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="positive"):
        Nav2MotionBase(FakeNav2Action(), frame="map", speed_mps=0.0, initial_pose=Pose(0, 0))


def test_the_readme_table_is_the_mapping_in_the_code() -> None:
    from pathlib import Path

    from robot_mcp_navigation.motion.nav2.error_codes import CODES, FAILURES

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    for name, failure in FAILURES.items():
        codes = ", ".join(str(c) for c, n in sorted(CODES.items()) if n == name) or "any other"
        row = (
            f"| `{name}` | {codes} | {'yes' if failure.recoverable else 'no'} | {failure.what} "
            f"| {'; '.join(failure.suggestions)} |"
        )
        assert row in readme, f"README row for {name} is stale"
