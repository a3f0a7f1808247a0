from __future__ import annotations

import pytest

from robot_mcp_kit.tasks import TaskTable


def test_created_tasks_are_running_with_their_extra_fields() -> None:
    table = TaskTable("navigation", id_prefix="nav")
    info = table.create("navigate_to", est_duration_s=9.5, destination="kitchen")
    assert info.task_id.startswith("nav-")
    assert (info.state, info.est_duration_s, info.server, info.tool) == (
        "running",
        9.5,
        "navigation",
        "navigate_to",
    )
    assert info.model_dump()["destination"] == "kitchen"
    assert table.get(info.task_id) == info
    assert info.task_id in table
    assert len(table) == 1


def test_explicit_task_ids_are_used_and_must_be_unique() -> None:
    table = TaskTable()
    assert table.create("watch", task_id="watch-1").task_id == "watch-1"
    with pytest.raises(ValueError, match="already exists"):
        table.create("watch", task_id="watch-1")


def test_finish_sets_the_terminal_state_and_merges_results() -> None:
    table = TaskTable()
    info = table.create("navigate_to", destination="dock")
    done = table.finish(info.task_id, "succeeded", result={"duration_s": 3})
    dumped = done.model_dump()
    assert done.state == "succeeded"
    assert dumped["result"] == {"duration_s": 3}
    assert dumped["destination"] == "dock"
    assert dumped["finished_at"] >= dumped["started_at"]
    assert table.get(info.task_id) == done


def test_finish_refuses_unknown_ids_and_non_terminal_states() -> None:
    table = TaskTable()
    with pytest.raises(KeyError):
        table.finish("nope", "failed")
    info = table.create("x")
    with pytest.raises(ValueError, match="terminal"):
        table.finish(info.task_id, "running")


def test_list_filters_by_state_in_creation_order() -> None:
    table = TaskTable()
    a, b, c = (table.create("x") for _ in range(3))
    table.finish(b.task_id, "cancelled")
    assert [t.task_id for t in table.list()] == [a.task_id, b.task_id, c.task_id]
    assert [t.task_id for t in table.list(["running"])] == [a.task_id, c.task_id]
    assert [t.task_id for t in table.list(("cancelled", "failed"))] == [b.task_id]
    assert table.list([]) == []


def test_only_the_newest_finished_tasks_are_remembered() -> None:
    table = TaskTable(max_finished=2)
    running = table.create("x")
    ids = [table.create("x").task_id for _ in range(4)]
    for task_id in ids:
        table.finish(task_id, "succeeded")
    assert [t.task_id for t in table.list()] == [running.task_id, *ids[2:]]
    with pytest.raises(ValueError):
        TaskTable(max_finished=-1)
