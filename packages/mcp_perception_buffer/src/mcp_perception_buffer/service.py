"""What the perception tools do, independent of MCP: reads of the rolling buffer, the
blocking wait, the polling loops (graph discovery, watcher arming) and the watcher tasks."""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

import structlog

from mcp_perception_buffer import views
from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.config import PerceptionConfig
from mcp_perception_buffer.ros_side import TopicFollower
from mcp_perception_buffer.watchers import WatcherService
from robot_mcp_kit.models import TaskState
from robot_ros_bridge import RosBridgeError
from robot_ros_bridge.vision_tasks import VisionTasks

logger = structlog.get_logger(__name__)
_WAIT_SLICE_S = 0.25
T = TypeVar("T")


class PerceptionError(Exception):
    def __init__(self, code: str, detail: str) -> None:
        super().__init__(f"{code}: {detail}")
        self.code, self.detail = code, detail


class Perception:
    def __init__(
        self,
        config: PerceptionConfig,
        buffer: RollingBuffer,
        watchers: WatcherService,
        vision_tasks: VisionTasks,
        follower: TopicFollower | None = None,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self._config = config
        self._buffer = buffer
        self._watchers = watchers
        self._vision = vision_tasks
        self._follower = follower
        self._clock = clock
        self._waiters: set[tuple[asyncio.AbstractEventLoop, asyncio.Event]] = set()
        self._waiters_lock = threading.Lock()
        self._loops: list[asyncio.Task[None]] = []
        self._home: asyncio.AbstractEventLoop | None = None
        self._buffer.add_listener(self._on_write)

    # -- life cycle ----------------------------------------------------------------------
    async def start(self) -> None:
        """Start polling and watchers on the running loop (the service's home loop).

        Tools may be called from another loop (the MCP transport's); anything that touches
        watcher state hops to the home loop.
        """
        self._home = asyncio.get_running_loop()
        await self._watchers.start()
        if self._follower is not None:
            self._loops.append(asyncio.create_task(self._graph_loop(), name="graph-poll"))
        self._loops.append(asyncio.create_task(self._watch_loop(), name="watch-poll"))

    async def close(self) -> None:
        for task in self._loops:
            task.cancel()
        for task in self._loops:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._loops.clear()
        await self._watchers.close()
        if self._follower is not None:
            self._follower.close()

    def _on_write(self, _skill: str, _item: object) -> None:
        """Buffer listener (any thread): wake every wait_for_result, on its own loop."""
        with self._waiters_lock:
            waiters = list(self._waiters)
        for loop, event in waiters:
            if not loop.is_closed():
                loop.call_soon_threadsafe(event.set)

    async def _at_home(self, fn: Callable[..., T], *args: Any) -> T:
        home = self._home
        if home is None or home is asyncio.get_running_loop():
            return fn(*args)

        async def call() -> T:
            return fn(*args)

        return await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(call(), home))

    async def sync_graph(self) -> None:
        if self._follower is not None:
            await asyncio.to_thread(self._follower.sync)

    async def sync_watchers(self) -> None:
        try:
            skills = await self._vision.list()
        except RosBridgeError as error:
            logger.warning("watch_poll_failed", error=error.code, detail=error.detail)
            return
        self._watchers.refresh(skills)

    async def _graph_loop(self) -> None:
        while True:
            try:
                await self.sync_graph()
            except Exception:  # a polling loop is a boundary: log and keep polling
                logger.exception("graph_poll_failed")
            await asyncio.sleep(self._config.graph_poll_s)

    async def _watch_loop(self) -> None:
        while True:
            try:
                await self.sync_watchers()
            except Exception:  # a polling loop is a boundary: log and keep polling
                logger.exception("watch_poll_crashed")
            await asyncio.sleep(self._config.watch_poll_s)

    # -- reads ---------------------------------------------------------------------------
    def _now(self) -> float:
        return self._clock()

    def _refresh(self, skill: str) -> None:
        """Retire entries of publishers that left the graph before reading ``skill``."""
        if self._follower is not None:
            self._follower.refresh(skill)

    def what_do_you_see(self) -> dict[str, Any]:
        for skill in self._buffer.skills():
            self._refresh(skill)
        buffers = [b for s in self._buffer.skills() if (b := self._buffer.snapshot(s))]
        return views.scene_view(buffers, self._now(), self._config.stale_after_s)

    def _snapshot(self, skill: str) -> Any:
        self._refresh(skill)
        buf = self._buffer.snapshot(skill)
        if buf is None:
            known = ", ".join(self._buffer.skills()) or "none"
            raise PerceptionError(
                "unknown_skill",
                f"no buffered results for skill {skill!r} (buffered: {known}). If you just "
                "instantiated it, call wait_for_result; list running skills with "
                "skill_control.list_running_skills.",
            )
        return buf

    def get_latest(self, skill: str) -> dict[str, Any]:
        return views.latest_view(self._snapshot(skill), self._now(), self._config.stale_after_s)

    def get_history(self, skill: str, seconds: float) -> dict[str, Any]:
        if seconds <= 0:
            raise PerceptionError("invalid_seconds", "seconds must be greater than 0")
        return views.history_view(
            self._snapshot(skill), seconds, self._now(), self._config.stale_after_s
        )

    def list_buffers(self) -> dict[str, Any]:
        followed = self._follower.followed() if self._follower is not None else {}
        for skill in self._buffer.skills():
            self._refresh(skill)
        now = self._now()
        entries = [
            views.buffer_summary(buf, followed.get(skill, []), now, self._config.stale_after_s)
            for skill in self._buffer.skills()
            if (buf := self._buffer.snapshot(skill)) is not None
        ]
        stamps = [e["stamp"] for e in entries if e["stamp"] is not None]
        view = views.freshness(max(stamps) if stamps else None, now, self._config.stale_after_s)
        view["buffers"] = entries
        view["following"] = sorted(followed)
        return view

    async def wait_for_result(
        self, skill: str, timeout_s: float, after_stamp: float | None = None
    ) -> dict[str, Any]:
        """The latest result of ``skill`` once one (newer than ``after_stamp``) is buffered."""
        timeout_s = min(max(timeout_s, 0.0), self._config.max_wait_s)
        deadline = time.monotonic() + timeout_s
        changed = asyncio.Event()
        waiter = (asyncio.get_running_loop(), changed)
        with self._waiters_lock:
            self._waiters.add(waiter)
        try:
            return await self._wait(skill, timeout_s, deadline, after_stamp, changed)
        finally:
            with self._waiters_lock:
                self._waiters.discard(waiter)

    async def _wait(
        self,
        skill: str,
        timeout_s: float,
        deadline: float,
        after_stamp: float | None,
        changed: asyncio.Event,
    ) -> dict[str, Any]:
        while True:
            changed.clear()
            self._refresh(skill)
            buf = self._buffer.snapshot(skill)
            if buf is not None:
                last = buf.last_stamp()
                if last is not None and (after_stamp is None or last > after_stamp):
                    return views.latest_view(buf, self._now(), self._config.stale_after_s)
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise PerceptionError(
                    "timeout",
                    f"no result for skill {skill!r} within {timeout_s:g} s. Check the skill "
                    "runs (skill_control.list_running_skills) and is enabled; call again to "
                    "keep waiting.",
                )
            if self._follower is not None and skill not in self._follower.followed():
                await self.sync_graph()  # just instantiated: discover it now, not next poll
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(min(remaining, _WAIT_SLICE_S)):
                    await changed.wait()

    async def health(self) -> dict[str, Any]:
        """Event delivery to the brain and what is followed; ``status`` is the worst of them."""
        events = await self._at_home(self._watchers.event_health)
        running = await self._at_home(self._watchers.list, ["running"])
        followed = self._follower.followed() if self._follower is not None else {}
        status = "ok" if events.get("status") in ("ok", "not_posting") else "degraded"
        return {
            "status": status,
            "events": events,
            "watchers_running": len(running),
            "following": sorted(followed),
        }

    # -- watcher tasks ------------------------------------------------------------------
    async def get_task(self, task_id: str) -> dict[str, Any]:
        info = await self._at_home(self._watchers.get, task_id)
        if info is None:
            raise PerceptionError("unknown_task", f"no watcher task {task_id!r}")
        return info.model_dump(mode="json")

    async def list_tasks(self, states: list[TaskState] | None = None) -> dict[str, Any]:
        tasks = await self._at_home(self._watchers.list, states)
        return {"tasks": [t.model_dump(mode="json") for t in tasks]}

    async def cancel_task(self, task_id: str, stop_skill: bool = True) -> dict[str, Any]:
        """Disarm the watcher (its terminal event is queued) and, by default, stop its skill.

        A skill that cannot be stopped (already gone, node unreachable) does not undo the
        cancel: the answer says ``skill_stopped: false`` and why.
        """
        was = await self._at_home(self._watchers.get, task_id)
        info = await self._at_home(self._watchers.cancel, task_id)
        if info is None:
            raise PerceptionError("unknown_task", f"no watcher task {task_id!r}")
        result = info.model_dump(mode="json")
        if not stop_skill or (was is not None and was.state != "running"):
            result["skill_stopped"] = False
            return result
        skill = str(result.get("skill") or task_id.removeprefix("watch-"))
        try:
            await self._vision.manage(skill, "delete")
        except RosBridgeError as error:
            logger.warning("watch_skill_stop_failed", skill=skill, error=error.code)
            result.update(skill_stopped=False, skill_stop_error=error.code, detail=error.detail)
        else:
            result["skill_stopped"] = True
        return result
