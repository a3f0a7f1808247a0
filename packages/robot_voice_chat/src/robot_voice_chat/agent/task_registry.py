"""Async tasks (spec §5.4): recognition of TaskInfo results, the live handle map, event
formatting for the planner (progress stays out of the conversation) and reconciliation."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any

from robot_mcp_kit.models import TaskEvent, TaskFailure

TERMINAL_EVENTS = frozenset({"task_done", "task_failed"})


@dataclass
class TaskHandle:
    task_id: str
    server: str
    tool: str
    step_id: str | None
    mission_id: str
    state: str = "running"
    last_progress: str = ""
    skill_id: str | None = None  # a watcher's skill, stopped with the task
    skill_server: str | None = None
    last_progress_at: float = 0.0  # monotonic time of the latest progress event
    # Wall-clock time the starting call was sent. Task ids can be reused (a watcher is
    # "watch-<skill_id>"); an event the server stamped before this instance existed belongs
    # to an earlier one. Servers share the brain's clock (loopback, ARCHITECTURE §1).
    since: float = 0.0
    # the label of the task this one re-issued after a supervision lapse (agent.lapse): the
    # planner keeps waiting on the task it started and reads this one's events under its name
    shown_as: str | None = None

    def predates(self, event: TaskEvent) -> bool:
        return event.ts < self.since

    @property
    def label(self) -> str:
        return self.shown_as or f"[task {self.task_id} {self.server}.{self.tool}]"


def parse_task_info(text: str) -> dict[str, Any] | None:
    """A tool result is an async task iff it is JSON with ``task_id`` and state running."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if (
        isinstance(data, dict)
        and isinstance(data.get("task_id"), str)
        and data.get("state", "running") == "running"
    ):
        return data
    return None


def _num(value: Any) -> str:
    return f"{value:g}" if isinstance(value, int | float) else str(value)


def progress_detail(payload: dict[str, Any]) -> str:
    """ "ETA 9 s · 82 %" from whatever progress fields the server sent."""
    parts = []
    eta = payload.get("eta_s", payload.get("eta"))
    if isinstance(eta, int | float):
        parts.append(f"ETA {eta:.0f} s")
    pct = payload.get("pct", payload.get("percent"))
    fraction = payload.get("progress", payload.get("fraction"))
    if isinstance(pct, int | float):
        parts.append(f"{pct:.0f} %")
    elif isinstance(fraction, int | float):
        parts.append(f"{fraction * 100:.0f} %")
    message = payload.get("message")
    if isinstance(message, str) and message:
        parts.append(message)
    return " · ".join(parts) or json.dumps(payload, separators=(",", ":"))[:120]


def trigger_of(payload: dict[str, Any]) -> dict[str, Any]:
    trigger = payload.get("trigger")
    if isinstance(trigger, dict):
        return trigger
    if isinstance(trigger, str):
        return {"type": trigger, "name": trigger}
    return {}


def format_event(event: TaskEvent, label: str) -> str | None:
    """The compact user-role line for the planner; ``None`` for progress (token hygiene)."""
    payload = event.payload
    if event.type == "progress":
        return None
    if event.type == "task_failed":
        failure = TaskFailure.model_validate(
            {"error_code": "UNKNOWN", "message": "", **payload} if isinstance(payload, dict) else {}
        )
        text = f"{label} failed {failure.error_code}"
        text += " (recoverable)" if failure.recoverable else " (not recoverable)"
        text += f": {failure.message}"
        if failure.suggestions:
            text += " suggestions: " + ", ".join(failure.suggestions)
        return text
    if event.type == "trigger_fired":
        trigger = trigger_of(payload)
        name = trigger.get("type") or trigger.get("name") or "trigger"
        value = next((trigger[k] for k in ("value", "seconds", "threshold") if k in trigger), "")
        text = f"{label} trigger_fired: {name} {_num(value)}".rstrip()
        eta = payload.get("eta_s")
        if isinstance(eta, int | float):
            text += f" (eta {eta:.1f}s)"
        return text
    if event.type == "task_done":
        result = payload.get("result", payload)
        return f"{label} done: {json.dumps(result, separators=(',', ':'))[:400]}"
    return f"{label} {event.type}: {json.dumps(payload, separators=(',', ':'))[:400]}"


class TaskRegistry:
    """Live task handles by task id (every mission; orphans are anything not in here)."""

    def __init__(self) -> None:
        self._handles: dict[str, TaskHandle] = {}

    def register(self, handle: TaskHandle) -> None:
        self._handles[handle.task_id] = handle

    def get(self, task_id: str) -> TaskHandle | None:
        return self._handles.get(task_id)

    def resolve(self, event: TaskEvent) -> TaskHandle | None:
        """Update the handle for ``event``; terminal events retire it."""
        handle = self._handles.get(event.task_id)
        if handle is None:
            return None
        if event.type == "progress":
            handle.last_progress = progress_detail(event.payload)
            handle.last_progress_at = time.monotonic()
        elif event.type in TERMINAL_EVENTS:
            handle.state = "succeeded" if event.type == "task_done" else "failed"
            del self._handles[event.task_id]
        return handle

    def live(self, mission_id: str | None = None, server: str | None = None) -> list[TaskHandle]:
        return [
            h
            for h in self._handles.values()
            if (mission_id is None or h.mission_id == mission_id)
            and (server is None or h.server == server)
        ]

    def progressed(self, mission_id: str, within_s: float) -> bool:
        """Did a live task of the mission report progress in the last ``within_s``?"""
        since = time.monotonic() - within_s
        return any(h.last_progress_at >= since for h in self.live(mission_id))

    def drop(self, task_id: str) -> TaskHandle | None:
        return self._handles.pop(task_id, None)

    def snapshot(self, mission_id: str) -> str:
        lines = [
            f"{h.task_id} {h.server}.{h.tool} {h.state}"
            + (f" (latest progress: {h.last_progress})" if h.last_progress else "")
            for h in self.live(mission_id)
        ]
        return "; ".join(lines) or "none"


def running_task_ids(text: str) -> set[str] | None:
    """Task ids in a ``list_tasks`` result (a list, or ``{"tasks": [...]}``); None if unparsable."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if isinstance(data, dict):
        data = data.get("tasks", data.get("result"))
    if not isinstance(data, list):
        return None
    return {
        str(item["task_id"])
        for item in data
        if isinstance(item, dict)
        and "task_id" in item
        and item.get("state", "running") == "running"
    }


def server_restarted_event(handle: TaskHandle) -> TaskEvent:
    failure = TaskFailure(
        error_code="SERVER_RESTARTED",
        message=f"{handle.server} restarted and no longer knows task {handle.task_id}",
        recoverable=True,
        suggestions=["retry"],
    )
    return TaskEvent(
        task_id=handle.task_id,
        server=handle.server,
        tool=handle.tool,
        type="task_failed",
        seq=0,
        ts=time.time(),
        payload=failure.model_dump(),
    )
