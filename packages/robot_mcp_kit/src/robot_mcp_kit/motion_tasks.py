"""MotionTasks: what every motion server's service does around its domain (navigation's drives,
manipulation's picks and places, a dock's docking), said once.

- **One motion at a time.** :meth:`MotionTasks.claim` takes the slot before the goal is sent (a
  parallel call meanwhile is the domain's *busy* error) and the task's runner frees it.
- **A task exists only once the robot took the goal** (:meth:`register`); the domain releases the
  slot when the robot refused it.
- **The Async Task Contract's events** (ARCHITECTURE §4.3): exactly one terminal event per task
  (:meth:`succeed` posts ``task_done``; :meth:`fail` posts ``task_failed`` with a TaskFailure,
  state ``cancelled`` or ``failed``); no progress or trigger event after a cancellation was
  asked for (:meth:`emit_live`); an event-sink failure never stops the bookkeeping.
- **Supervision**: a :class:`MotionGate` (``robot_mcp_kit.supervision.Supervision`` is one)
  admits motion (:meth:`refuse_if_stopped`); :meth:`stop` is what the watchdog calls; the
  shared cancel-reason rule (:meth:`blame_supervision`) says a motion that ended while motion
  was refused, before anyone asked it to stop, was ended by supervision — the stop's cancel-all
  (or the dead-man lock) reached the robot before the watchdog's own cancel — never "on its own".

The domain supplies its words (:class:`MotionWords`: its busy and refused errors and its log
prefix) and how to halt the robot.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable, Coroutine, Iterable
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar

import structlog

from robot_mcp_kit.models import EventType, TaskFailure, TaskInfo, TaskState
from robot_mcp_kit.motion_errors import UnknownTaskError
from robot_mcp_kit.supervision import Refusal
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable

logger = structlog.get_logger(__name__)


class GateRefusal(Protocol):
    @property
    def code(self) -> str: ...

    @property
    def detail(self) -> str: ...


class MotionGate(Protocol):
    """Whether motion may start now: ``None`` (go ahead) or a refusal with a stable ``code``
    (``Supervision`` has exactly this shape)."""

    def refusal(self) -> GateRefusal | None: ...


class OpenGate:
    """Admits every motion (no supervisor configured)."""

    def refusal(self) -> GateRefusal | None:
        return None


def lapse_reason(refused: GateRefusal) -> str:
    """Why motion ended for ``refused``, in the words of ``Supervision``'s refusals."""
    return Refusal(refused.code, refused.detail).reason


@dataclass
class MotionTask:
    """One running motion; a domain subclasses it with its goal."""

    task_id: str
    tool: str
    cancel_reason: str | None = None
    latest: dict[str, Any] | None = None  # the live progress get_task shows
    runner: asyncio.Task[TaskInfo] | None = None
    started: float = field(default_factory=time.monotonic)
    live: list[asyncio.Task[None]] = field(default_factory=list)  # events sent in the background


T = TypeVar("T", bound=MotionTask)


@dataclass(frozen=True)
class MotionWords(Generic[T]):
    """A domain's names for what the service says: ``log`` prefixes its log events
    (``<log>_refused``, ``_stopped``, ``_stop_slow``); the errors it raises."""

    log: str
    busy: Callable[[T], Exception]
    refused: Callable[[str, str], Exception]  # (code, detail)


class MotionTasks(Generic[T]):
    def __init__(
        self,
        events: EventSink,
        tasks: TaskTable,
        words: MotionWords[T],
        halt: Callable[[T | None], Awaitable[None]],
        *,
        gate: MotionGate | None = None,
        settle_timeout_s: float = 5.0,
    ) -> None:
        """``halt(active)``: stop the robot (and cancel ``active``'s goal, if any);
        ``settle_timeout_s``: how long a stop waits for the task to end."""
        self._events = events
        self._tasks = tasks
        self._words = words
        self._halt = halt
        self.gate: MotionGate = gate or OpenGate()
        self.settle_timeout_s = settle_timeout_s
        self.active: T | None = None

    # -- queries -------------------------------------------------------------------------

    @property
    def moving(self) -> bool:
        """A motion is being taken or runs (what a lapsed lease must end)."""
        return self.active is not None

    def get_task(self, task_id: str) -> TaskInfo:
        info = self._tasks.get(task_id)
        if info is None:
            raise UnknownTaskError(f"no task {task_id!r} on this server (it may predate a restart)")
        active = self.active
        if active is not None and active.task_id == task_id and active.latest is not None:
            return info.model_copy(update={"progress": active.latest})
        return info

    def list_tasks(self, states: Iterable[TaskState] | None = None) -> list[TaskInfo]:
        return self._tasks.list(states)

    # -- admission -----------------------------------------------------------------------

    def refusal(self) -> GateRefusal | None:
        return self.gate.refusal()

    def refuse_if_stopped(self, **log: Any) -> None:
        """Raise the domain's refused error while the gate refuses motion."""
        refused = self.gate.refusal()
        if refused is not None:
            logger.warning(
                f"{self._words.log}_refused", code=refused.code, detail=refused.detail, **log
            )
            raise self._words.refused(refused.code, refused.detail)

    def claim(self, task: T) -> T:
        """Hold the slot for ``task`` while the robot takes its goal; the domain's busy error
        while another motion holds it."""
        active = self.active
        if active is not None:
            raise self._words.busy(active)
        self.active = task
        return task

    def release(self, task: T) -> None:
        """Free the slot of a motion that never started (the robot refused its goal)."""
        if self.active is task:
            self.active = None

    def register(self, task: T, est_duration_s: float, **extra: Any) -> TaskInfo:
        """The task, now that the robot took its goal (running)."""
        return self._tasks.create(
            task.tool, est_duration_s=est_duration_s, task_id=task.task_id, **extra
        )

    def run(self, task: T, body: Coroutine[Any, Any, TaskInfo]) -> None:
        """Run ``body`` (it follows the goal and ends with :meth:`succeed` or :meth:`fail`);
        the slot is free once it returned."""

        async def runner() -> TaskInfo:
            try:
                return await body
            finally:
                self.release(task)

        task.runner = asyncio.create_task(runner(), name=task.task_id)

    # -- stopping ------------------------------------------------------------------------

    async def stop(self, reason: str) -> TaskInfo | None:
        """Halt at once; cancel the running motion (if any) and return its final state."""
        started = time.monotonic()
        active = self.active
        if active is not None and active.cancel_reason is None:
            active.cancel_reason = reason
        await self._halt(active)
        final = await self._wait_finished(active)
        logger.info(
            f"{self._words.log}_stopped",
            reason=reason,
            task_id=active.task_id if active else None,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        return final

    async def cancel_task(self, task_id: str) -> TaskInfo:
        """Cancel ``task_id``; a task that already ended is returned unchanged."""
        info = self.get_task(task_id)
        active = self.active
        if active is None or active.task_id != task_id:
            return info
        final = await self.stop(reason="cancel_task")
        return final if final is not None else self.get_task(task_id)

    async def close(self) -> None:
        await self.stop(reason="shutdown")

    async def _wait_finished(self, task: T | None) -> TaskInfo | None:
        if task is None:
            return None
        if task.runner is None:  # its goal is still being taken
            return self._tasks.get(task.task_id)
        try:
            async with asyncio.timeout(self.settle_timeout_s):
                return await asyncio.shield(task.runner)
        except TimeoutError:
            logger.warning(f"{self._words.log}_stop_slow", task_id=task.task_id)
            return self._tasks.get(task.task_id)

    def blame_supervision(
        self, task: T, ended: bool, reason: Callable[[GateRefusal], str] = lapse_reason
    ) -> None:
        """The shared cancel-reason rule (see the module doc): ``ended`` — the robot ended the
        motion its own way (canceled, aborted) — while the gate refuses motion and nobody asked
        for a stop yet: the cancel reason is the refusal's (``reason`` words it)."""
        refused = self.gate.refusal()
        if ended and task.cancel_reason is None and refused is not None:
            task.cancel_reason = reason(refused)

    # -- events --------------------------------------------------------------------------

    async def succeed(self, task: T, result: dict[str, Any]) -> TaskInfo:
        info = self._tasks.finish(task.task_id, "succeeded", result=result)
        await self.emit(task, "task_done", result)
        return info

    async def fail(
        self, task: T, state: TaskState, failure: TaskFailure, common: dict[str, Any]
    ) -> TaskInfo:
        """End ``task`` as ``cancelled`` or ``failed``: its ``task_failed`` event carries the
        failure, ``common`` (what the domain says of every end) and the state."""
        info = self._tasks.finish(task.task_id, state, error=failure.model_dump())
        await self.emit(task, "task_failed", {**failure.model_dump(), **common, "state": state})
        return info

    async def emit_live(self, task: T, type: EventType, payload: dict[str, Any]) -> None:
        """A non-terminal event, unless cancellation was asked for meanwhile."""
        if task.cancel_reason is None:
            await self.emit(task, type, payload)

    def emit_live_soon(self, task: T, type: EventType, payload: dict[str, Any]) -> None:
        """:meth:`emit_live` in the background (from a feedback callback); :meth:`flush_live`
        awaits them before the terminal event, so events stay in order."""
        task.live.append(
            asyncio.get_running_loop().create_task(self.emit_live(task, type, payload))
        )

    async def flush_live(self, task: T) -> None:
        await asyncio.gather(*task.live)

    async def emit(self, task: T, type: EventType, payload: dict[str, Any]) -> None:
        try:
            await self._events.emit(task.task_id, task.tool, type, payload)
        except Exception:  # an event-sink failure must never stop the robot's bookkeeping
            logger.exception("event_emit_failed", task_id=task.task_id, type=type)


class OnMotionTasks(Generic[T]):
    """A domain service's base: the queries and commands it answers straight from its
    ``motion`` (``get_task``, ``list_tasks``, ``cancel_task``, ``close``, ``moving``)."""

    motion: MotionTasks[T]

    @property
    def moving(self) -> bool:
        """A motion is being taken or runs (what a lapsed lease must end)."""
        return self.motion.moving

    def get_task(self, task_id: str) -> TaskInfo:
        return self.motion.get_task(task_id)

    def list_tasks(self, states: Iterable[TaskState] | None = None) -> list[TaskInfo]:
        return self.motion.list_tasks(states)

    async def cancel_task(self, task_id: str) -> TaskInfo:
        return await self.motion.cancel_task(task_id)

    async def close(self) -> None:
        await self.motion.close()
