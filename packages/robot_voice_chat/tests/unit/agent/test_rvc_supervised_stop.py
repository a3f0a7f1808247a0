"""What the brain says and does when a motion server is out of reach or someone else drives
(issue 27): never "Stopped." about a motion it could not stop; motion it did not start,
reported while latched, is stopped."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.tools.base import ToolOutcome

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


class Navigation:
    """The harness's navigation server, reachable or not (killed)."""

    def __init__(self) -> None:
        self.reachable = True

    def answer(self, result: Any) -> Any:
        if not self.reachable:
            return ToolOutcome(text="error: server 'navigation' is not connected", is_error=True)
        return result


async def supervised(tmp_path: Path, planner: FakeLLM) -> tuple[Harness, Navigation]:
    nav = Navigation()
    h = make_harness(tmp_path, planner, supervisor=(0.05, 0.3))
    h.tools.add(
        "navigation.supervise",
        lambda a: nav.answer({"supervised": True, "latched": a["latched"]}),
        holder="string",
    )
    h.tools.add("navigation.stop_navigation", lambda a: nav.answer({"stopped": True}))
    h.tools.add("navigation.cancel_task", lambda a: nav.answer({"state": "cancelled"}))
    assert h.supervisor is not None
    await h.supervisor.start()
    await async_wait_until(lambda: h.supervisor and h.supervisor.fresh("navigation"), 5, "lease")
    return h, nav


@pytest.fixture
async def harness(tmp_path: Path) -> Any:
    h, nav = await supervised(tmp_path, FakeLLM([PLAN, WAIT]))
    yield h, nav
    assert h.supervisor is not None
    await h.supervisor.aclose()


async def test_stop_while_navigation_is_unreachable_says_what_is_true(harness: Any) -> None:
    h, nav = harness
    await h.executor.start("drive to the kitchen")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
    nav.reachable = False  # kill -9 of the navigation server

    told = await h.executor.on_user_turn("stop")

    assert not told.startswith("Stopped.")
    assert "could not reach my navigation" in told
    assert "My supervision of it lapsed at" in told
    assert "holds itself stopped" in told
    assert told.endswith("Should I continue or abort?")
    assert h.latch.latched


async def test_stop_with_navigation_reached_is_the_plain_question(harness: Any) -> None:
    h, _ = harness
    await h.executor.start("drive to the kitchen")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")

    assert await h.executor.on_user_turn("stop") == "Stopped. Should I continue or abort?"


async def test_a_lost_navigation_server_is_reported_without_a_false_stop_hint(
    harness: Any,
) -> None:
    h, nav = harness
    await h.executor.start("drive to the kitchen")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
    nav.reachable = False

    h.tools.states["navigation"] = "disconnected"
    await h.executor.on_server_lost("navigation")  # the backend's disconnect listener

    text = " ".join(h.speech.spoken)
    assert "lost contact with my navigation" in text
    assert "holds itself stopped" in text
    assert "Say stop to halt me" not in text
    busy = await h.executor.on_user_turn("how far is it")
    assert "Say stop to halt me" not in busy


def orphan(task_id: str, type: str = "progress") -> TaskEvent:
    payload: dict[str, Any] = {"pct": 10.0}
    if type == "task_failed":
        payload = {"error_code": "CANCELLED", "message": "x", "recoverable": True}
    return TaskEvent(
        event_id=f"e-{task_id}-{type}",
        task_id=task_id,
        server="navigation",
        tool="navigate_to",
        type=type,  # type: ignore[arg-type]
        seq=1,
        ts=time.time(),
        payload=payload,
    )


async def test_a_drive_someone_else_started_is_stopped_when_it_reports_while_latched(
    harness: Any,
) -> None:
    h, _ = harness
    await h.latch.stop("operator", "stop")

    handled = await h.executor.on_task_event(orphan("nav-other"))
    await h.executor.on_task_event(orphan("nav-other"))  # stopped once, not per event

    assert handled is False
    await async_wait_until(
        lambda: h.tools.called("navigation.cancel_task") == [{"task_id": "nav-other"}],
        5,
        "the orphan cancelled",
    )
    await async_wait_until(
        lambda: len(h.tools.called("navigation.stop_navigation")) == 1, 5, "stop tool called"
    )


async def test_orphan_events_while_not_latched_or_already_over_stop_nothing(
    harness: Any,
) -> None:
    h, _ = harness
    await h.executor.on_task_event(orphan("nav-a"))  # not latched: someone else's business
    await h.latch.stop("operator", "stop")
    await h.executor.on_task_event(orphan("nav-b", "task_failed"))  # over already

    assert h.tools.called("navigation.cancel_task") == []
    assert h.tools.called("navigation.stop_navigation") == []
