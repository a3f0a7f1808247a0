from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from robot_mcp_kit.models import EventType, TaskEvent
from robot_mcp_kit.outbox import (
    Appended,
    OutboxError,
    OutboxFullError,
    OutboxLockedError,
    SqliteOutbox,
)


def draft(task_id: str, type_: EventType = "progress") -> TaskEvent:
    payload = {"error_code": "E", "message": "m"} if type_ == "task_failed" else {}
    return TaskEvent(task_id=task_id, server="s", tool="t", type=type_, seq=0, payload=payload)


def add(
    outbox: SqliteOutbox,
    task_id: str,
    type_: EventType = "progress",
    max_events: int = 100,
    protected: frozenset[int] = frozenset(),
) -> TaskEvent:
    return append(outbox, task_id, type_, max_events, protected).event


def append(
    outbox: SqliteOutbox,
    task_id: str,
    type_: EventType = "progress",
    max_events: int = 100,
    protected: frozenset[int] = frozenset(),
) -> Appended:
    base = draft(task_id, type_)
    return outbox.append(
        partial(lambda d, seq: d.model_copy(update={"seq": seq}), base),
        task_id,
        max_events,
        protected,
    )


def test_seq_counts_per_task_and_survives_reopening(tmp_path: Path) -> None:
    path = tmp_path / "o.sqlite"
    outbox = SqliteOutbox(path)
    assert outbox.open(counter_retention_s=3600) == []
    assert [add(outbox, "a").seq for _ in range(3)] == [0, 1, 2]
    assert add(outbox, "b").seq == 0
    outbox.close()

    reopened = SqliteOutbox(path)
    pending = reopened.open(counter_retention_s=3600)
    assert [(e.task_id, e.seq) for e in pending] == [("a", 0), ("a", 1), ("a", 2), ("b", 0)]
    assert reopened.count == 4
    assert add(reopened, "a").seq == 3
    reopened.close()


def test_stored_bytes_are_the_event_json(tmp_path: Path) -> None:
    outbox = SqliteOutbox(tmp_path / "o.sqlite")
    outbox.open(3600)
    event = add(outbox, "a", "task_done")
    outbox.close()
    again = SqliteOutbox(tmp_path / "o.sqlite")
    (stored,) = again.open(3600)
    assert TaskEvent.model_validate_json(stored.body) == event
    assert stored.event_id == event.event_id
    again.close()


def test_removing_delivered_events_keeps_the_counter(tmp_path: Path) -> None:
    outbox = SqliteOutbox(tmp_path / "o.sqlite")
    outbox.open(3600)
    row_id = append(outbox, "a").stored.row_id
    assert outbox.remove(row_id) is True
    assert outbox.remove(row_id) is False
    assert outbox.count == 0
    assert add(outbox, "a").seq == 1
    outbox.close()


def test_old_counters_of_finished_tasks_are_pruned_on_open(tmp_path: Path) -> None:
    path = tmp_path / "o.sqlite"
    outbox = SqliteOutbox(path)
    outbox.open(3600)
    add(outbox, "a")
    outbox.close()
    again = SqliteOutbox(path)
    (stored,) = again.open(counter_retention_s=-1)  # "a" still has an event: kept
    again.remove(stored.row_id)
    again.close()
    third = SqliteOutbox(path)
    third.open(counter_retention_s=-1)
    assert add(third, "a").seq == 0
    third.close()


def test_pressure_drops_progress_then_triggers_and_spares_protected_rows(tmp_path: Path) -> None:
    outbox = SqliteOutbox(tmp_path / "o.sqlite")
    outbox.open(3600)
    add(outbox, "a", "progress")
    add(outbox, "a", "progress")
    add(outbox, "a", "trigger_fired")
    first_row = 1
    appended = outbox.append(
        lambda seq: draft("b", "task_done").model_copy(update={"seq": seq}),
        "b",
        3,
        frozenset({first_row}),
    )
    assert [d.seq for d in appended.dropped] == [1]  # row 1 is being posted: spared
    add(outbox, "c", "watch_event", max_events=3, protected=frozenset({first_row}))  # drops trigger
    with pytest.raises(OutboxFullError, match="max_outbox=3"):
        add(outbox, "d", "task_failed", max_events=3, protected=frozenset({first_row}))
    assert outbox.count == 3
    assert add(outbox, "d", "task_failed", max_events=3).task_id == "d"  # row 1 now droppable
    outbox.close()


def test_a_second_opener_of_a_live_outbox_gets_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "o.sqlite"
    first = SqliteOutbox(path)
    first.open(3600)
    second = SqliteOutbox(path, lock_timeout_s=0.1)
    with pytest.raises(OutboxLockedError, match="in use"):
        second.open(3600)
    first.close()
    second.open(3600)
    second.close()


def test_an_unopened_outbox_refuses_work(tmp_path: Path) -> None:
    with pytest.raises(OutboxError, match="not open"):
        SqliteOutbox(tmp_path / "o.sqlite").remove(1)
