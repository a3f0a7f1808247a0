"""Watchers end with their mission (issue 13 item 9, brain side): cancelled through the
server that owns the task (perception), their skill stopped through skill_control."""

from __future__ import annotations

import time
from pathlib import Path

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.services.llm.fake import FakeLLM, reply

WATCHER = {
    "skill_id": "watch_for",
    "task_id": "watch-watch_for",
    "state": "running",
    "server": "perception",
    "tool": "instantiate_skill",
}


def watch_event(server: str) -> TaskEvent:
    return TaskEvent(
        task_id="watch-watch_for",
        server=server,
        tool="instantiate_skill",
        type="watch_event",
        seq=1,
        ts=time.time(),
        payload={"output": "door_open", "value": True},
    )


async def test_a_watcher_is_cancelled_on_perception_and_its_skill_stopped_at_finish(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            reply("", ("skill_control.instantiate_skill", {"template": "watch_for"})),
            reply("", ("wait_for_events", {"reason": "door"})),
            reply("", ("finish_mission", {"outcome": "succeeded", "summary": "It opened."})),
        ]
    )
    h = make_harness(tmp_path, planner)
    h.tools.add("skill_control.instantiate_skill", lambda a: WATCHER, template="string")
    h.tools.add("skill_control.stop_skill", lambda a: {"stopped": True}, skill_id="string")
    h.tools.add("perception.cancel_task", lambda a: {"state": "cancelled"}, task_id="string")
    await h.executor.start("tell me when the door opens")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "waiting")

    assert await h.executor.on_task_event(watch_event("perception"))  # the owner's event
    await h.executor.wait_idle(5)

    assert h.tools.called("perception.cancel_task") == [{"task_id": "watch-watch_for"}]
    assert h.tools.called("skill_control.stop_skill") == [{"skill_id": "watch_for"}]
    assert h.tools.called("skill_control.cancel_task") == []
    assert h.executor.registry.live() == []


async def test_a_watcher_ends_when_its_mission_is_aborted(tmp_path: Path) -> None:
    planner = FakeLLM(
        [
            reply("", ("skill_control.instantiate_skill", {"template": "watch_for"})),
            reply("", ("wait_for_events", {"reason": "door"})),
        ]
    )
    h = make_harness(tmp_path, planner)
    h.tools.add("skill_control.instantiate_skill", lambda a: WATCHER, template="string")
    h.tools.add("skill_control.stop_skill", lambda a: {"stopped": True}, skill_id="string")
    h.tools.add("perception.cancel_task", lambda a: {"state": "cancelled"}, task_id="string")
    await h.executor.start("watch the door")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "waiting")
    assert not await h.executor.on_task_event(watch_event("skill_control"))  # not its owner

    await h.executor.shutdown()

    assert h.tools.called("perception.cancel_task") == [{"task_id": "watch-watch_for"}]
    assert h.tools.called("skill_control.stop_skill") == [{"skill_id": "watch_for"}]


async def test_a_new_watcher_is_not_failed_by_the_previous_instances_late_events(
    tmp_path: Path,
) -> None:
    """Issue 23 item 6: "watch for a dog" 1 s after a finished "watch for the scissors" got
    the first watcher's CANCELLED (same task id, kept ORPHAN_GRACE_S) and failed at once."""
    planner = FakeLLM(
        [
            reply("", ("skill_control.instantiate_skill", {"template": "watch_for"})),
            reply("", ("wait_for_events", {"reason": "dog"})),
            reply("", ("finish_mission", {"outcome": "succeeded", "summary": "A dog."})),
        ]
    )
    h = make_harness(tmp_path, planner)
    h.tools.add("skill_control.instantiate_skill", lambda a: WATCHER, template="string")
    h.tools.add("skill_control.stop_skill", lambda a: {"stopped": True}, skill_id="string")
    h.tools.add("perception.cancel_task", lambda a: {"state": "cancelled"}, task_id="string")
    # the previous watcher's terminal event, stamped when it was cancelled, arrives late
    previous_end = TaskEvent(
        task_id="watch-watch_for",
        server="perception",
        tool="instantiate_skill",
        type="task_failed",
        seq=4,
        ts=time.time() - 1.0,
        payload={"error_code": "CANCELLED", "message": "the watcher was cancelled"},
    )
    assert not await h.executor.on_task_event(previous_end)  # no mission: kept as orphan
    await h.executor.start("watch for a dog")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "waiting")
    run = h.executor.run
    assert run is not None
    assert [h.task_id for h in h.executor.registry.live()] == ["watch-watch_for"]
    assert not any("CANCELLED" in line for line in run.inbox)
    # it arriving again (outbox retry) after the new instance registered is not news either
    assert not await h.executor.on_task_event(previous_end)
    assert h.executor.registry.live()

    assert await h.executor.on_task_event(watch_event("perception"))  # the new one's event
    await h.executor.wait_idle(5)
    assert h.executor.store.recent(1)[0].state == "succeeded"
