"""A third motion server built from the README's recipe ("Add a motion capability"): a dock in
five small files beside this test (port, docking, tools, composition). It behaves as navigation
and manipulation do, because what they share is the kit's: one motion at a time, the Async Task
Contract's events, the gate, the stop tool, the task tools, the guard, the cancel-reason rule,
the supervision watchdog and the process's start-up."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcp import Client

from robot_mcp_kit.motion_serving import MotionSide
from robot_mcp_kit.supervision import Supervision
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.tool_calls import tool_answer

from .composition import DockApp, DockSettings, build_app, main
from .docking import DockingError

RECIPE = Path(__file__).parent
BRAIN = "brain"


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
async def app(clock: Clock) -> DockApp:
    supervision = Supervision(required=True, clock=clock)
    supervision.renew(BRAIN, 2.0, latched=False)
    return build_app(DockSettings(), supervision)


async def ended(app: DockApp, task_id: str) -> str:
    await async_wait_until(
        lambda: app.docker.motion.get_task(task_id).state != "running", 5.0, "the task ends"
    )
    return app.docker.motion.get_task(task_id).state


def test_the_recipe_is_a_few_small_files() -> None:
    files = {p.name: len(p.read_text().splitlines()) for p in RECIPE.glob("*.py")}
    product = {name: n for name, n in files.items() if not name.startswith("test_")}
    assert set(product) == {"port.py", "docking.py", "tools.py", "composition.py"}
    assert sum(product.values()) < 320, product


async def test_a_dock_runs_as_one_task_with_progress_then_one_terminal_event(app: DockApp) -> None:
    async with Client(app.server) as client:
        info = await tool_answer(client, "dock")
        assert (info["state"], info["tool"]) == ("running", "dock")
        busy = await tool_answer(client, "dock")
        assert busy["_error"]["error"] == "DOCKING_BUSY"
        app.dock.goals[0].on_feedback(40.0)
        app.dock.goals[0].on_feedback(90.0)
        live = await tool_answer(client, "get_task", {"task_id": info["task_id"]})
        assert live["progress"] == {"pct": 90.0}
        app.dock.goals[0].finish("succeeded")
        assert await ended(app, info["task_id"]) == "succeeded"
        listed = await tool_answer(client, "list_tasks", {"states": ["succeeded"]})
        assert [t["task_id"] for t in listed["tasks"]] == [info["task_id"]]
    assert app.events.types(info["task_id"]) == ["progress", "progress", "task_done"]
    assert app.events.events[-1].payload == {"docked": True}
    assert not app.docker.motion.moving


async def test_the_stop_tool_cancels_with_its_reason_and_no_progress_follows(
    app: DockApp,
) -> None:
    async with Client(app.server) as client:
        info = await tool_answer(client, "dock")
        stopped = await tool_answer(client, "stop_docking")
        assert (stopped["stopped"], stopped["moving"]) == (True, False)
        assert stopped["cancelled_task"]["state"] == "cancelled"
        assert "stop_docking" in stopped["cancelled_task"]["error"]["message"]
        app.dock.goals[0].on_feedback(50.0)  # a late feedback after the cancel
        again = await tool_answer(client, "stop_docking")
        assert again["cancelled_task"] is None
    assert app.events.types(info["task_id"]) == ["task_failed"]
    assert app.events.events[-1].payload["state"] == "cancelled"


async def test_cancel_task_and_unknown_tasks_answer_as_the_other_servers_do(app: DockApp) -> None:
    async with Client(app.server) as client:
        info = await tool_answer(client, "dock")
        cancelled = await tool_answer(client, "cancel_task", {"task_id": info["task_id"]})
        assert cancelled["state"] == "cancelled"
        unchanged = await tool_answer(client, "cancel_task", {"task_id": info["task_id"]})
        assert unchanged == cancelled
        for tool in ("get_task", "cancel_task"):
            missing = await tool_answer(client, tool, {"task_id": "dock-404"})
            assert missing["_error"]["error"] == "UNKNOWN_TASK"


async def test_an_unavailable_dock_starts_no_task_and_frees_the_slot(app: DockApp) -> None:
    app.dock.refuse = True
    async with Client(app.server) as client:
        refused = await tool_answer(client, "dock")
        assert refused["_error"]["error"] == "DOCK_UNAVAILABLE"
        app.dock.refuse = False
        assert (await tool_answer(client, "dock"))["state"] == "running"
    assert len(app.docker.motion.list_tasks()) == 1


async def test_motion_is_refused_without_a_lease_and_a_dock_that_ends_meanwhile_was_ended_by_it(
    app: DockApp, clock: Clock
) -> None:
    info = await app.docker.dock()
    clock.now += 10.0  # the lease lapsed; the dock's own stop (its lock) ended the goal first
    app.dock.goals[0].finish("canceled")
    assert await ended(app, info.task_id) == "cancelled"
    failure = app.docker.motion.get_task(info.task_id).error
    assert failure is not None
    assert "lease" in failure["message"]
    with pytest.raises(DockingError) as refused:
        await app.docker.dock()
    assert refused.value.code == "NOT_SUPERVISED"


async def test_a_dock_that_stops_on_its_own_is_not_called_a_cancel(app: DockApp) -> None:
    info = await app.docker.dock()
    app.dock.goals[0].finish("canceled")  # the robot's own stop, nobody asked
    assert await ended(app, info.task_id) == "failed"
    assert app.events.events[-1].payload["error_code"] == "DOCK_FAILED"


async def test_running_starts_the_events_ends_motion_on_a_lapse_and_closes_everything(
    app: DockApp, clock: Clock
) -> None:
    closed: list[str] = []
    app.side = MotionSide(lambda: closed.append("ros side"))
    async with app.running():
        assert app.events.started
        info = await app.docker.dock()
        clock.now += 10.0  # the watchdog sees the lapse and stops the dock
        assert await ended(app, info.task_id) == "cancelled"
        assert app.dock.goals[0].cancel_requests == 1
        assert closed == []
    assert app.events.closed
    assert closed == ["ros side"]


def test_the_console_script_exits_2_on_a_bad_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DOCK_BROKEN", "1")
    with pytest.raises(SystemExit) as exited:
        main()
    assert exited.value.code == 2
