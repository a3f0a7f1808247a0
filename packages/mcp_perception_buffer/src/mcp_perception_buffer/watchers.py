"""Watchers (ARCHITECTURE.md §4.4): the ``watch: {output, equals}`` blocks of running skills,
evaluated on their output values; a rising edge (false -> true, and the first true after
arming) emits exactly one ``watch_event``. A watcher that ends — cancelled, or its skill left
``list_vision_tasks`` — posts one terminal ``task_failed`` (a ``TaskFailure`` with
``error_code`` ``CANCELLED`` or ``SKILL_STOPPED``, ``recoverable: true``, plus ``state:
"cancelled"``, ``reason`` and how often it fired), as navigation does for a cancelled task, so
the brain retires the task.

``WatchEvaluator`` is the pure edge detector; ``WatcherService`` arms/disarms from
``list_vision_tasks``, keeps the watcher tasks (kit ``TaskInfo``s, keyed by task id; a
stopped skill whose name is reused gets a fresh running task under the same id) and hands
events to the :class:`EventSink`.
Task ids are ``watch-<skill>``; the event ``tool`` is ``instantiate_skill`` (the
skill_control tool that started the watcher), ``server`` is ``perception``.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from dataclasses import dataclass, field
from typing import Any

import structlog

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.events import EventSink
from robot_mcp_kit.models import EventType, TaskInfo, TaskState

logger = structlog.get_logger(__name__)

WATCH_TOOL = "instantiate_skill"
_END_FAILURES: dict[str, dict[str, Any]] = {
    "cancelled_by_caller": {
        "error_code": "CANCELLED",
        "message": "the watcher was cancelled",
        "recoverable": True,
    },
    "skill_stopped": {
        "error_code": "SKILL_STOPPED",
        "message": "the watched skill is no longer running on the vision node",
        "recoverable": True,
        "suggestions": ["instantiate the watcher template again if still needed"],
    },
}
MAX_FIRED_AT = 20
"""How many fire times a watcher task reports (the most recent)."""


def watch_task_id(skill: str) -> str:
    return f"watch-{skill}"


@dataclass
class Watch:
    skill: str
    output: str
    equals: Any
    last: bool | None = None
    fired: int = 0
    fired_at: list[float] = field(default_factory=list)
    """Wall-clock times (unix s) of the most recent rising edges, oldest first."""

    @property
    def task_id(self) -> str:
        return watch_task_id(self.skill)


class WatchEvaluator:
    """Pure rising-edge detection per skill."""

    def __init__(self) -> None:
        self._watches: dict[str, Watch] = {}

    def arm(self, skill: str, output: str, equals: Any) -> Watch:
        current = self._watches.get(skill)
        if current is not None and (current.output, current.equals) == (output, equals):
            return current
        watch = Watch(skill, output, equals)
        self._watches[skill] = watch
        return watch

    def disarm(self, skill: str) -> Watch | None:
        return self._watches.pop(skill, None)

    def get(self, skill: str) -> Watch | None:
        return self._watches.get(skill)

    def armed(self) -> list[Watch]:
        return list(self._watches.values())

    def observe(self, skill: str, output: str, value: Any) -> Watch | None:
        """Feed one value; returns the watch if this value is a rising edge."""
        watch = self._watches.get(skill)
        if watch is None or watch.output != output:
            return None
        now_true = value == watch.equals
        rising = now_true and watch.last is not True
        watch.last = now_true
        if rising:
            watch.fired += 1
            watch.fired_at = [*watch.fired_at, round(time.time(), 3)][-MAX_FIRED_AT:]
            return watch
        return None


class WatcherService:
    def __init__(self, buffer: RollingBuffer, sink: EventSink, server: str = "perception") -> None:
        self._buffer = buffer
        self._sink = sink
        self._server = server
        self._tasks: dict[str, TaskInfo] = {}
        self._eval = WatchEvaluator()
        self._cancelled: set[str] = set()
        self._queue: asyncio.Queue[tuple[str, EventType, dict[str, Any]]] = asyncio.Queue()
        self._worker: asyncio.Task[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    # -- life cycle ----------------------------------------------------------------------
    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        await self._sink.start()
        self._worker = asyncio.create_task(self._deliver(), name="watch-events")
        self._buffer.add_listener(self._on_buffer_write)

    async def close(self, drain_timeout_s: float = 2.0) -> None:
        with contextlib.suppress(TimeoutError):  # hand queued (terminal) events to the sink
            async with asyncio.timeout(drain_timeout_s):
                await self._queue.join()
        if self._worker is not None:
            self._worker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._worker
        await self._sink.close()

    async def drain(self) -> None:
        """Wait until every queued event was handed to the sink."""
        await self._queue.join()

    # -- arming --------------------------------------------------------------------------
    def refresh(self, skills: list[dict[str, Any]]) -> None:
        """Arm a watcher per listed skill with a ``watch`` block; end those whose skill left."""
        listed: set[str] = set()
        for info in skills:
            name, watch = info.get("name"), info.get("watch")
            if not isinstance(name, str) or not isinstance(watch, dict):
                continue
            output = watch.get("output")
            if not isinstance(output, str):
                continue
            listed.add(name)
            if name in self._cancelled or self._eval.get(name) is not None:
                continue
            self._arm(name, output, watch.get("equals", True))
        for watch in self._eval.armed():
            if watch.skill not in listed:
                self._end(watch.skill, "cancelled", reason="skill_stopped")
        self._cancelled &= listed  # a later skill with the same name may be watched again

    def _arm(self, skill: str, output: str, equals: Any) -> None:
        watch = self._eval.arm(skill, output, equals)
        task_id = watch.task_id
        self._tasks.pop(task_id, None)  # re-insert: newest last
        self._tasks[task_id] = TaskInfo(
            task_id=task_id,
            state="running",
            server=self._server,
            tool=WATCH_TOOL,
            skill=skill,
            output=output,
            equals=equals,
            started_at=round(time.time(), 3),
            **_firing(watch),
        )
        logger.info("watcher_armed", task_id=task_id, skill=skill, output=output)
        latest = self._buffer.latest_output(skill, output)
        if latest is not None:
            self._evaluate(skill, output, latest.value, latest.stamp)

    def _end(self, skill: str, state: TaskState, reason: str) -> TaskInfo | None:
        """Disarm ``skill``'s watcher, finish its task and queue the terminal event."""
        watch = self._eval.disarm(skill)
        if watch is None:
            return None
        logger.info("watcher_ended", task_id=watch.task_id, state=state, reason=reason)
        current = self._tasks[watch.task_id]
        finished = TaskInfo.model_validate(
            {
                **current.model_dump(),
                **_firing(watch),
                "reason": reason,
                "state": state,
                "finished_at": round(time.time(), 3),
            }
        )
        self._tasks[watch.task_id] = finished
        failure = _END_FAILURES[reason]
        payload = {**failure, "skill": skill, "state": state, "reason": reason, **_firing(watch)}
        self._queue.put_nowait((watch.task_id, "task_failed", payload))
        return finished

    # -- tools ---------------------------------------------------------------------------
    def event_health(self) -> dict[str, Any]:
        return {**self._sink.health(), "queued": self._queue.qsize()}

    def get(self, task_id: str) -> TaskInfo | None:
        return self._tasks.get(task_id)

    def list(self, states: list[TaskState] | None = None) -> list[TaskInfo]:
        return [t for t in self._tasks.values() if states is None or t.state in states]

    def cancel(self, task_id: str) -> TaskInfo | None:
        """Disarm the watcher (no more events). Returns None for an unknown task id."""
        info = self._tasks.get(task_id)
        if info is None:
            return None
        if info.state != "running":
            return info
        skill = str(getattr(info, "skill", task_id.removeprefix("watch-")))
        self._cancelled.add(skill)
        ended = self._end(skill, "cancelled", reason="cancelled_by_caller")
        return ended if ended is not None else self._tasks.get(task_id)

    # -- evaluation ----------------------------------------------------------------------
    def _on_buffer_write(self, skill: str, item: Any) -> None:
        """Buffer listener, called on a ROS executor thread: hop to the event loop."""
        output = getattr(item, "output", None)
        loop = self._loop
        if output is None or loop is None or loop.is_closed():
            return
        loop.call_soon_threadsafe(self._evaluate, skill, output, item.value, item.stamp)

    def _evaluate(self, skill: str, output: str, value: Any, stamp: float) -> None:
        watch = self._eval.observe(skill, output, value)
        if watch is None:
            return
        payload = {
            "skill": skill,
            "output": output,
            "value": value,
            "equals": watch.equals,
            "stamp": stamp,
            "fired": watch.fired,
            "topic": f"/vision/{skill}/{output}",
        }
        logger.info("watch_fired", task_id=watch.task_id, fired=watch.fired)
        current = self._tasks.get(watch.task_id)
        if current is not None:
            self._tasks[watch.task_id] = TaskInfo.model_validate(
                {**current.model_dump(), **_firing(watch)}
            )
        self._queue.put_nowait((watch.task_id, "watch_event", payload))

    async def _deliver(self) -> None:
        while True:
            task_id, type_, payload = await self._queue.get()
            try:
                await self._sink.emit(task_id, WATCH_TOOL, type_, payload)
            except Exception:  # the delivery loop is a boundary: log, keep going
                logger.exception("watch_event_failed", task_id=task_id)
            finally:
                self._queue.task_done()


def _firing(watch: Watch) -> dict[str, Any]:
    """How often and when a watcher fired, as its task reports it."""
    return {
        "fired": watch.fired,
        "fired_at": list(watch.fired_at),
        "last_fired_at": watch.fired_at[-1] if watch.fired_at else None,
    }
