import time
from typing import Any

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.events import LoggingEventSink, RecordingEventSink
from mcp_perception_buffer.watchers import WatcherService, WatchEvaluator
from robot_mcp_kit.models import TaskFailure
from robot_stack_testing import async_wait_until

WATCHED = [{"name": "door", "watch": {"output": "open", "equals": True}}]
BELL = {"name": "bell", "watch": {"output": "rang", "equals": True}}


async def ring_the_bell_and_hear_it(buffer: RollingBuffer, sink: RecordingEventSink) -> None:
    """A write after the ones under test whose watch event must follow theirs (the service
    evaluates writes and posts events in order): once it is posted, every earlier write has
    been evaluated and its event, if any, posted before it."""
    buffer.add_output("bell", "rang", True, 9.0)
    await async_wait_until(
        lambda: any(e[0] == "watch-bell" for e in sink.events), 5.0, "the bell's event"
    )


def door_events(sink: RecordingEventSink) -> list[tuple[Any, ...]]:
    return [e for e in sink.events if e[0] == "watch-door"]


def test_only_rising_edges_fire() -> None:
    ev = WatchEvaluator()
    ev.arm("door", "open", True)
    values = [False, True, True, False, True, True]
    fired = [ev.observe("door", "open", v) is not None for v in values]
    assert fired == [False, True, False, False, True, False]
    assert ev.observe("door", "other", True) is None
    assert ev.observe("nobody", "open", True) is None
    door = ev.get("door")
    assert door is not None
    assert door.fired == 2


def test_the_first_true_after_arming_fires_and_re_arming_the_same_watch_keeps_state() -> None:
    ev = WatchEvaluator()
    first = ev.arm("door", "open", True)
    assert ev.observe("door", "open", True) is first
    assert ev.arm("door", "open", True) is first
    assert ev.observe("door", "open", True) is None
    assert ev.arm("door", "open", "yes") is not first


async def test_a_watcher_posts_exactly_once_per_rising_edge() -> None:
    buffer = RollingBuffer()
    sink = RecordingEventSink()
    service = WatcherService(buffer, sink)
    await service.start()
    try:
        service.refresh([*WATCHED, BELL])
        assert service.get("watch-door") is not None
        for value in (False, True, True, True):
            buffer.add_output("door", "open", value, 1.0)
        await async_wait_until(lambda: len(sink.events) >= 1, 5.0, "one event")
        buffer.add_output("door", "open", False, 2.0)
        buffer.add_output("door", "open", True, 3.0)
        buffer.add_output("door", "open", True, 4.0)
        await ring_the_bell_and_hear_it(buffer, sink)
        events = door_events(sink)
        assert [e[:3] for e in events] == [("watch-door", "instantiate_skill", "watch_event")] * 2
        assert events[1][3]["stamp"] == 3.0
        assert events[1][3]["fired"] == 2
        assert events[0][3]["topic"] == "/vision/door/open"
    finally:
        await service.close()


async def test_arming_evaluates_the_already_buffered_value() -> None:
    buffer = RollingBuffer()
    buffer.add_output("door", "open", True, 1.0)
    sink = RecordingEventSink()
    service = WatcherService(buffer, sink)
    await service.start()
    try:
        service.refresh(WATCHED)
        await service.drain()
        assert len(sink.events) == 1
    finally:
        await service.close()


async def test_cancel_disarms_and_polling_does_not_re_arm_it() -> None:
    buffer = RollingBuffer()
    sink = RecordingEventSink()
    service = WatcherService(buffer, sink)
    await service.start()
    try:
        service.refresh([*WATCHED, BELL])
        cancelled = service.cancel("watch-door")
        assert cancelled is not None
        assert cancelled.state == "cancelled"
        again = service.cancel("watch-door")
        assert again is not None
        assert again.state == "cancelled"
        service.refresh([*WATCHED, BELL])
        buffer.add_output("door", "open", True, 1.0)
        await ring_the_bell_and_hear_it(buffer, sink)
        events = door_events(sink)
        assert [e[:3] for e in events] == [("watch-door", "instantiate_skill", "task_failed")]
        assert events[0][3]["reason"] == "cancelled_by_caller"
        assert events[0][3]["error_code"] == "CANCELLED"
        assert events[0][3]["state"] == "cancelled"
        assert service.cancel("watch-nobody") is None
        assert [t.task_id for t in service.list(["cancelled"])] == ["watch-door"]
        assert [t.task_id for t in service.list(["running"])] == ["watch-bell"]
    finally:
        await service.close()


async def test_a_stopped_skill_ends_its_watcher_and_a_new_skill_of_that_name_re_arms() -> None:
    buffer = RollingBuffer()
    service = WatcherService(buffer, LoggingEventSink())
    await service.start()
    try:
        service.refresh(WATCHED)
        service.refresh([{"name": "door"}, {"name": "x", "watch": {"equals": 1}}, {"watch": {}}])
        await service.drain()
        ended = service.get("watch-door")
        assert ended is not None
        assert ended.state == "cancelled"
        assert ended.model_dump()["reason"] == "skill_stopped"
        service.refresh(WATCHED)
        again = service.get("watch-door")
        assert again is not None
        assert again.state == "running"
        await service._sink.emit("watch-door", "instantiate_skill", "watch_event", {})
    finally:
        await service.close()


async def test_a_watcher_whose_skill_was_deleted_posts_one_terminal_event() -> None:
    buffer = RollingBuffer()
    sink = RecordingEventSink()
    service = WatcherService(buffer, sink)
    await service.start()
    try:
        service.refresh(WATCHED)
        buffer.add_output("door", "open", True, 1.0)
        await async_wait_until(lambda: len(sink.events) >= 1, 5.0, "the watch_event")
        service.refresh([])
        service.refresh([])
        await service.drain()
    finally:
        await service.close()
    assert [e[2] for e in sink.events] == ["watch_event", "task_failed"]
    terminal = sink.events[1][3]
    assert terminal["reason"] == "skill_stopped"
    assert TaskFailure.model_validate(terminal).error_code == "SKILL_STOPPED"
    assert terminal["fired"] == 1
    assert terminal["last_fired_at"] == terminal["fired_at"][-1]


async def test_get_shows_how_often_and_when_a_running_watcher_fired() -> None:
    buffer = RollingBuffer()
    sink = RecordingEventSink()
    service = WatcherService(buffer, sink)
    await service.start()
    try:
        service.refresh(WATCHED)
        before = time.time()
        for stamp, value in enumerate((True, False, True)):
            buffer.add_output("door", "open", value, float(stamp))
        await async_wait_until(lambda: len(sink.events) >= 2, 5.0, "two watch_events")
        info = service.get("watch-door")
    finally:
        await service.close()
    assert info is not None
    dumped = info.model_dump()
    assert dumped["state"] == "running"
    assert dumped["fired"] == 2
    assert len(dumped["fired_at"]) == 2
    assert before - 1 <= dumped["fired_at"][0] <= dumped["last_fired_at"] <= time.time() + 1


async def test_closing_hands_queued_terminal_events_to_the_sink() -> None:
    sink = RecordingEventSink()
    service = WatcherService(RollingBuffer(), sink)
    await service.start()
    service.refresh(WATCHED)
    service.cancel("watch-door")
    await service.close()
    assert [e[2] for e in sink.events] == ["task_failed"]
