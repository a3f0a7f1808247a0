"""The latched software stop: set by every stop path, cleared only by an operator's Clear stop.

A software stop request (a controlled stop through the robot's own controller), not an
emergency-stop device: the robot's hardware emergency stop remains required.
Setting it is synchronous (motion is refused from the next line on); persisting runs off the
event loop. Clearing persists first: if the disk write fails the latch stays set.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from typing import Any

import structlog

from robot_voice_chat.control.latch_store import LatchState, LatchStore
from robot_voice_chat.operator import current_operator

logger = structlog.get_logger(__name__)
SAFETY_STOP_LATCHED = "SAFETY_STOP_LATCHED"
NO_LOGIN = "local operator (no login)"
Listener = Callable[[LatchState], Awaitable[None]]


class NotLatchedError(RuntimeError):
    """Clear stop while no stop is latched."""


def acting(default: str = NO_LOGIN) -> str:
    """Who acts: the logged-in operator, else ``default``."""
    return current_operator.get() or default


def latched_sentence(state: LatchState) -> str:
    when = time.strftime("%H:%M:%S", time.localtime(state.since)) if state.since else "earlier"
    return (
        f"The robot is stopped: a software stop is latched (since {when}, by {state.by}: "
        f"{state.reason}). An operator must press Clear stop before it moves again."
    )


class SafetyLatch:
    def __init__(self, store: LatchStore) -> None:
        self.store = store
        self._state = store.load()
        self._lock = asyncio.Lock()
        self._listeners: list[Listener] = []
        self._clearing = False
        if self._state.latched:
            logger.warning("safety_latch_restored", **self._state.model_dump())

    @property
    def state(self) -> LatchState:
        return self._state.model_copy()

    @property
    def latched(self) -> bool:
        return self._state.latched

    def add_listener(self, listener: Listener) -> None:
        self._listeners.append(listener)

    def engage(self, by: str, reason: str) -> bool:
        """Latch now (no await: nothing can move after this line). True when newly latched."""
        if self._state.latched and not self._clearing:
            return False
        self._clearing = False  # a stop during a clear's write wins over the clear
        self._state = LatchState(latched=True, since=time.time(), by=by, reason=reason)
        return True

    async def stop(self, by: str, reason: str) -> LatchState:
        """Latch (if not yet), persist and tell listeners. A second stop keeps the first."""
        self.engage(by, reason)
        record = {"event": "stop", "ts": time.time(), "by": by, "reason": reason}
        async with self._lock:
            state = self._state
            started = time.monotonic()
            try:
                await asyncio.to_thread(self.store.save, state, record)
            except OSError:
                logger.exception("safety_latch_persist_failed")  # still latched in memory
            logger.warning(
                "safety_latch_set",
                by=by,
                reason=reason,
                duration_ms=round((time.monotonic() - started) * 1000, 1),
            )
        await self._notify()
        return self.state

    async def clear(self, by: str, reason: str) -> LatchState:
        """Clear after persisting the clear; resumes nothing (missions stay as they are)."""
        async with self._lock:
            cleared = self._state
            if not cleared.latched:
                raise NotLatchedError("no software stop is latched")
            record: dict[str, Any] = {
                "event": "clear",
                "ts": time.time(),
                "by": by,
                "reason": reason,
                "stop": cleared.model_dump(),
            }
            self._clearing = True
            try:
                await asyncio.to_thread(self.store.save, LatchState(), record)
            finally:
                clearing, self._clearing = self._clearing, False
            # a stop that came during the write keeps its latch
            if clearing and self._state is cleared:
                self._state = LatchState()
            logger.warning("safety_latch_cleared", by=by, reason=reason, stop=cleared.model_dump())
        await self._notify()
        return self.state

    async def _notify(self) -> None:
        for listener in self._listeners:
            await listener(self.state)
