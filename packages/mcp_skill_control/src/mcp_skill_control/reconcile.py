"""Reconciling a ``create_vision_task`` call that timed out (issue 13 item 10).

A timeout does not mean the node did nothing: the request may still be processed. After a
timeout, :meth:`CreateReconciler.find` polls ``list_vision_tasks`` for the skill; if it shows
up the caller adopts it. If it does not within ``confirm_s``, the caller reports the error and
:meth:`CreateReconciler.sweep_later` keeps watching for ``sweep_s``: a skill that appears late
is deleted, so a failed instantiate never leaves an orphan skill running. A later successful
create of the same name cancels that sweep (the skill is then the caller's own).
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from typing import Any

import structlog

from robot_ros_bridge import RosBridgeError
from robot_ros_bridge.vision_tasks import VisionTasks

logger = structlog.get_logger(__name__)


class CreateReconciler:
    def __init__(
        self,
        tasks: VisionTasks,
        *,
        confirm_s: float,
        sweep_s: float,
        poll_s: float = 0.25,
    ) -> None:
        self._tasks = tasks
        self._confirm_s = confirm_s
        self._sweep_s = sweep_s
        self._poll_s = poll_s
        self._sweeps: dict[str, asyncio.Task[None]] = {}

    async def find(self, skill: dict[str, Any]) -> bool:
        """Whether the node lists ``skill`` (same name and mode) within ``confirm_s``."""
        return await self._appears(skill, self._confirm_s)

    def sweep_later(self, skill: dict[str, Any]) -> None:
        """Delete ``skill`` if it appears within ``sweep_s`` (a create that landed late)."""
        name = str(skill["name"])
        self.cancel_sweep(name)
        self._sweeps[name] = asyncio.create_task(self._sweep(skill), name=f"sweep-{name}")

    def cancel_sweep(self, name: str) -> None:
        sweep = self._sweeps.pop(name, None)
        if sweep is not None:
            sweep.cancel()

    def sweeping(self) -> list[str]:
        return [name for name, task in self._sweeps.items() if not task.done()]

    async def close(self) -> None:
        sweeps = list(self._sweeps.values())
        self._sweeps.clear()
        for sweep in sweeps:
            sweep.cancel()
        for sweep in sweeps:
            with contextlib.suppress(asyncio.CancelledError):
                await sweep

    async def _sweep(self, skill: dict[str, Any]) -> None:
        name = str(skill["name"])
        try:
            if await self._appears(skill, self._sweep_s):
                await self._tasks.manage(name, "delete")
                logger.warning("orphan_skill_removed", skill_id=name)
        except RosBridgeError as error:
            logger.error("orphan_skill_sweep_failed", skill_id=name, error=error.code)
        finally:
            if self._sweeps.get(name) is asyncio.current_task():
                del self._sweeps[name]

    async def _appears(self, skill: dict[str, Any], within_s: float) -> bool:
        deadline = time.monotonic() + within_s
        while True:
            try:
                listed = await self._tasks.list()
            except RosBridgeError as error:
                logger.info("reconcile_list_failed", skill_id=skill["name"], error=error.code)
            else:
                if any(_same(info, skill) for info in listed):
                    return True
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            await asyncio.sleep(min(self._poll_s, remaining))


def _same(info: dict[str, Any], skill: dict[str, Any]) -> bool:
    return info.get("name") == skill["name"] and info.get("mode") == skill.get("mode")
