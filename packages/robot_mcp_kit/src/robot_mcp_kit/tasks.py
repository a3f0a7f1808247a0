"""TaskTable: the in-memory task table behind get_task / cancel_task / list_tasks."""

from __future__ import annotations

import builtins
import time
import uuid
from collections import OrderedDict
from collections.abc import Iterable
from typing import Any

from robot_mcp_kit.models import TERMINAL_STATES, TaskInfo, TaskState


class TaskTable:
    """Tasks of one server process, oldest first. Running tasks are kept until finished;
    at most ``max_finished`` finished tasks are remembered (the oldest are forgotten)."""

    def __init__(
        self, server: str | None = None, *, id_prefix: str = "task", max_finished: int = 1000
    ) -> None:
        if max_finished < 0:
            raise ValueError("max_finished must be >= 0")
        self._server = server
        self._id_prefix = id_prefix
        self._max_finished = max_finished
        self._tasks: OrderedDict[str, TaskInfo] = OrderedDict()

    def create(
        self,
        tool: str,
        est_duration_s: float | None = None,
        task_id: str | None = None,
        **extra: Any,
    ) -> TaskInfo:
        """Register a running task; ``task_id`` defaults to ``<prefix>-<12 hex>``.
        Raises ValueError if the id is already in the table."""
        task_id = task_id or f"{self._id_prefix}-{uuid.uuid4().hex[:12]}"
        if task_id in self._tasks:
            raise ValueError(f"task id {task_id!r} already exists")
        info = TaskInfo(
            task_id=task_id,
            state="running",
            est_duration_s=est_duration_s,
            server=self._server,
            tool=tool,
            started_at=round(time.time(), 3),
            **extra,
        )
        self._tasks[task_id] = info
        return info

    def get(self, task_id: str) -> TaskInfo | None:
        return self._tasks.get(task_id)

    def list(self, states: Iterable[TaskState] | None = None) -> builtins.list[TaskInfo]:
        """All tasks (oldest first), or those in one of ``states``."""
        wanted = None if states is None else frozenset(states)
        return [t for t in self._tasks.values() if wanted is None or t.state in wanted]

    def finish(self, task_id: str, state: TaskState, **extra: Any) -> TaskInfo:
        """Move a task to a terminal state, merging ``extra`` fields (e.g. ``result=``,
        ``error=``). Raises KeyError for an unknown id, ValueError for a non-terminal state."""
        if state not in TERMINAL_STATES:
            raise ValueError(f"finish() needs a terminal state, got {state!r}")
        current = self._tasks.get(task_id)
        if current is None:
            raise KeyError(task_id)
        updated = TaskInfo.model_validate(
            {
                **current.model_dump(),
                **extra,
                "state": state,
                "finished_at": round(time.time(), 3),
            }
        )
        self._tasks[task_id] = updated
        self._evict_finished()
        return updated

    def __len__(self) -> int:
        return len(self._tasks)

    def __contains__(self, task_id: object) -> bool:
        return task_id in self._tasks

    def _evict_finished(self) -> None:
        finished = [k for k, t in self._tasks.items() if t.state in TERMINAL_STATES]
        for task_id in finished[: max(0, len(finished) - self._max_finished)]:
            del self._tasks[task_id]
