"""MotionSupervisor: the brain's lease on every ``motion: true`` MCP server (issue 27).

Every ``lease_period_s`` (≤ 1 s) the brain calls each motion server's ``supervise`` tool with
a TTL (``lease_ttl_s``) and its latched software stop; a latch change is sent at once. A server
whose lease lapses — the brain was killed, hung, or cannot reach it — cancels its motion and
locks the robot's base through its dead-man lock (``robot_ros_bridge.dead_man_lock``), so
nothing moves without a live supervisor. This service holds the raw tool backend: the lease is
the brain's own control traffic, never a planner's call (the guard hides ``supervise``).

What it knows feeds what the brain says: a stop that could not reach a motion server is
reported with when that server's supervision lapsed (from then on its base holds itself
stopped), never as "Stopped." about a motion the brain could not reach.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import structlog

from robot_mcp_kit.supervision import SUPERVISE_TOOL
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import LatchState
from robot_voice_chat.services.tools.base import ToolBackend

logger = structlog.get_logger(__name__)

LeaseState = Literal["pending", "supervised", "unreachable", "unsupported", "refused"]


@dataclass
class LeaseView:
    """The brain's view of one motion server's lease."""

    server: str
    state: LeaseState = "pending"
    renewed_at: float | None = None  # monotonic time of the last answered renewal
    renewed_wall: float | None = None  # the same moment, wall clock (for sentences)
    server_latched: bool | None = None  # what the server said in its last answer
    detail: str = ""

    def lapses_at(self, ttl_s: float) -> float | None:
        """Monotonic time by which the server's lease has surely lapsed (None: never held)."""
        return None if self.renewed_at is None else self.renewed_at + ttl_s

    def as_dict(self, ttl_s: float, now: float) -> dict[str, Any]:
        lapses = self.lapses_at(ttl_s)
        return {
            "state": self.state,
            "fresh": lapses is not None and now < lapses and self.state == "supervised",
            "server_latched": self.server_latched,
            "detail": self.detail,
        }


class MotionSupervisor:
    def __init__(
        self,
        tools: ToolBackend,
        latch: SafetyLatch,
        *,
        period_s: float = 0.25,
        ttl_s: float = 0.8,
        holder: str | None = None,
        clock: Callable[[], float] = time.monotonic,
        wall: Callable[[], float] = time.time,
    ) -> None:
        if not 0 < period_s <= ttl_s / 2:
            raise ValueError("lease_period_s must be > 0 and at most half of lease_ttl_s")
        self.tools = tools
        self.latch = latch
        self.period_s = period_s
        self.ttl_s = ttl_s
        self.holder = holder or f"brain-{uuid.uuid4().hex[:8]}"
        self._clock = clock
        self._wall = wall
        self._views: dict[str, LeaseView] = {}
        self._wakes: dict[str, asyncio.Event] = {}
        self._renewed: dict[str, asyncio.Event] = {}  # set after each renewal attempt
        self._tasks: list[asyncio.Task[None]] = []

    # --- lifecycle ----------------------------------------------------------------------
    def motion_servers(self) -> list[str]:
        return [name for name, cfg in self.tools.servers().items() if cfg.motion]

    async def start(self) -> None:
        """One renewal loop per motion server; the latch's changes and (re)connections are
        sent at once."""
        self.latch.add_listener(self._on_latch)
        self.tools.add_connect_listener(self._on_connect)
        for server in self.motion_servers():
            self._views[server] = LeaseView(server)
            self._wakes[server] = asyncio.Event()
            self._renewed[server] = asyncio.Event()
            self._tasks.append(asyncio.create_task(self._loop(server), name=f"lease-{server}"))
        logger.info(
            "supervision_started",
            holder=self.holder,
            servers=self.motion_servers(),
            period_s=self.period_s,
            ttl_s=self.ttl_s,
        )

    async def aclose(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks.clear()

    def wake(self) -> None:
        """Renew every lease now (the latch changed)."""
        for event in self._wakes.values():
            event.set()

    async def _on_latch(self, state: LatchState) -> None:
        self.wake()

    async def _on_connect(self, server: str) -> None:
        if server in self._wakes:
            self._wakes[server].set()

    async def ensure_fresh(self, server: str, timeout_s: float | None = None) -> bool:
        """Before a motion call: a fresh lease on ``server`` (one is asked for at once when
        it has none, e.g. right after it connected), waiting at most ``timeout_s`` (a TTL by
        default). True when fresh; a server not supervised by this brain answers False."""
        view = self._views.get(server)
        if server not in self._wakes or view is None or view.state == "unsupported":
            return False  # not supervised by this brain: nothing to wait for
        if self._current(server):
            return True
        self._wakes[server].set()
        renewed = self._renewed[server]
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(self.ttl_s if timeout_s is None else timeout_s):
                while not self._current(server):
                    renewed.clear()
                    await renewed.wait()
        return self._current(server)

    def _current(self, server: str) -> bool:
        """Fresh, and the server has heard the brain's latch as it is now (a motion call right
        after the operator cleared the stop must not meet the server's old latch)."""
        view = self._views.get(server)
        return (
            self.fresh(server)
            and view is not None
            and view.server_latched is not None
            and view.server_latched == self.latch.latched
        )

    # --- the view -----------------------------------------------------------------------
    def view(self, server: str) -> LeaseView | None:
        return self._views.get(server)

    def fresh(self, server: str) -> bool:
        """The server holds a lease from us that has not run out."""
        view = self._views.get(server)
        lapses = view.lapses_at(self.ttl_s) if view is not None else None
        return (
            view is not None
            and view.state == "supervised"
            and lapses is not None
            and (self._clock() < lapses)
        )

    def all_fresh(self) -> bool:
        """Every motion server that takes a lease holds a fresh one (a server without the
        ``supervise`` tool is not supervised, and not counted)."""
        return all(
            self.fresh(server)
            for server, view in self._views.items()
            if view.state != "unsupported"
        )

    def lapsed_at(self, server: str) -> float | None:
        """Wall time at which ``server``'s lease ran out (None while it may still be fresh,
        or if it never held one)."""
        view = self._views.get(server)
        if view is None or view.renewed_at is None or view.renewed_wall is None:
            return None
        if self._clock() < view.renewed_at + self.ttl_s:
            return None
        return view.renewed_wall + self.ttl_s

    async def settle(self, server: str) -> tuple[Literal["lapsed", "latched", "unknown"], float]:
        """After a stop that ``server`` did not confirm: wait (at most a TTL and a period)
        until either its lease has surely run out (``lapsed``, with the wall time it did:
        from then on its base holds itself stopped) or it answered a renewal carrying the
        latched stop (``latched``); ``unknown`` if neither (it never held a lease)."""
        deadline = self._clock() + self.ttl_s + self.period_s
        self.wake()
        while True:
            view = self._views.get(server)
            lapsed = self.lapsed_at(server)
            if lapsed is not None:
                return "lapsed", lapsed
            if view is None or view.renewed_at is None:
                return "unknown", 0.0
            if self.fresh(server) and view.server_latched and self.latch.latched:
                return "latched", 0.0
            if self._clock() >= deadline:
                return "unknown", 0.0
            await asyncio.sleep(self.period_s / 4)

    def summary(self) -> dict[str, Any]:
        now = self._clock()
        return {
            "holder": self.holder,
            "period_s": self.period_s,
            "ttl_s": self.ttl_s,
            "servers": {s: v.as_dict(self.ttl_s, now) for s, v in self._views.items()},
        }

    # --- renewing -----------------------------------------------------------------------
    async def _loop(self, server: str) -> None:
        wake = self._wakes[server]
        while True:
            started = self._clock()
            try:
                await self.renew(server)
            except Exception:  # a renewal loop must outlive any one failure
                logger.exception("supervision_renewal_crashed", server=server)
            self._renewed[server].set()
            remaining = self.period_s - (self._clock() - started)
            if remaining > 0 and not wake.is_set():
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(remaining):
                        await wake.wait()
            wake.clear()

    async def renew(self, server: str) -> LeaseView:
        view = self._views.setdefault(server, LeaseView(server))
        tool = f"{server}.{SUPERVISE_TOOL}"
        states = self.tools.server_states()
        if states.get(server) != "connected":
            return self._set(view, "unreachable", f"{server} is not connected")
        if not self.tools.has_tool(tool):
            return self._set(view, "unsupported", f"{server} offers no {SUPERVISE_TOOL} tool")
        latch = self.latch.state
        arguments: dict[str, object] = {
            "holder": self.holder,
            "latched": latch.latched,
            "ttl_s": self.ttl_s,
            "reason": latch.reason if latch.latched else "",
        }
        outcome = await self.tools.call_tool(tool, arguments, self.ttl_s)
        answered_at, answered_wall = self._clock(), self._wall()
        answer = _json(outcome.text)
        if outcome.is_error or not isinstance(answer, dict):
            state: LeaseState = "refused" if isinstance(answer, dict) else "unreachable"
            return self._set(view, state, outcome.text[:200])
        view.renewed_at, view.renewed_wall = answered_at, answered_wall
        view.server_latched = bool(answer.get("latched"))
        return self._set(view, "supervised", "")

    def _set(self, view: LeaseView, state: LeaseState, detail: str) -> LeaseView:
        if view.state != state:
            log = logger.info if state == "supervised" else logger.warning
            log("supervision_lease", server=view.server, state=state, detail=detail)
        view.state, view.detail = state, detail
        return view


def _json(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return None
