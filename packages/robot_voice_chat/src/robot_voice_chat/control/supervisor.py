"""MotionSupervisor: the brain's lease on every ``motion: true`` MCP server (issues 27, 35, 39).

Every ``lease_period_s`` (≤ 1 s) the brain calls each motion server's ``supervise`` tool with
a TTL (``lease_ttl_s``) and its latched software stop; a latch change is sent at once. A server
whose lease lapses — the brain was killed, hung, or cannot reach it — cancels its motion and
locks the robot's base through its dead-man lock (``robot_ros_bridge.dead_man_lock``), so
nothing moves without a live supervisor. This service holds the raw tool backend: the lease is
the brain's own control traffic, never a planner's call (the guard hides ``supervise``).

A busy brain is not a dead one (issue 39): the renewals (``control.lease_renewal``) run on a
thread with its own event loop and its own MCP connections (``lease_tools``: same URLs,
transports and credential as the brain's), or in a child process this object mirrors
(``lease_process``: ``control.lease_mirror``), so a burst of chat turns or a slow request on
the brain's loop cannot delay them; without either (in-process fakes) they run as tasks on the
brain's loop. A latch change wakes them at once; each renewal's outcome is published as an
immutable view (``control.lease_view``); alarms and refused leases: ``control.lease_alarms``;
the brain's waits for a fresh lease: ``control.lease_waits``.

What it knows feeds what the brain says: a stop that could not reach a motion server is
reported with when that server's supervision lapsed (from then on its base holds itself
stopped), never as "Stopped." about a motion the brain could not reach.
"""

from __future__ import annotations

import asyncio
import dataclasses
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any, Literal

import structlog

from robot_voice_chat.control.alarms import NoticeHandler, SupervisionAlarm, SupervisionNotice
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import LatchState
from robot_voice_chat.control.lease_alarms import AlarmBook
from robot_voice_chat.control.lease_link import LeaseLink
from robot_voice_chat.control.lease_mirror import ProcessMirror
from robot_voice_chat.control.lease_renewal import LeaseRenewal
from robot_voice_chat.control.lease_view import LeaseState, LeaseView, RenewalStats
from robot_voice_chat.control.lease_waits import LeaseWaits
from robot_voice_chat.control.loop_calls import call_soon
from robot_voice_chat.services.tools.base import ToolBackend

__all__ = ["LeaseState", "LeaseView", "MotionSupervisor"]  # lease_child and tests import these

logger = structlog.get_logger(__name__)

START_TIMEOUT_S = 10.0  # the renewal thread's loop and backend come up within this
HEARTBEAT_S = 0.1  # the brain's loop shows it runs this often (the renewal thread reads it)
PROCESS_START_TIMEOUT_S = 30.0  # the renewal process imports, connects and says ready


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
        lease_tools: Callable[[], ToolBackend] | None = None,
        on_notice: NoticeHandler | None = None,
        hung_after_s: float = 5.0,
        lease_process: LeaseLink | None = None,
    ) -> None:
        """``lease_tools``: builds the renewals' own backend (called inside the renewal
        thread, whose loop then owns its connections); None: renew through ``tools`` on the
        brain's loop. ``on_notice``: the brain's answer to an alarm or a refused lease (by
        default an alarm latches the stop, a refusal is logged). ``hung_after_s``: a brain
        whose loop has not run for this long is hung, not busy: its renewal thread stops
        renewing, so the robot halts as for a dead brain (issue 27's "killed or hung").
        ``lease_process``: the renewals run in a child process over this link
        (``control.lease_link``); the brain's loop only mirrors what it reports."""
        if not 0 < period_s <= ttl_s / 2:
            raise ValueError("lease_period_s must be > 0 and at most half of lease_ttl_s")
        if lease_process is not None and lease_tools is not None:
            raise ValueError("the renewals run on a thread or in a process, not both")
        self.tools = tools
        self.latch = latch
        self.period_s = period_s
        self.ttl_s = ttl_s
        self.holder = holder or f"brain-{uuid.uuid4().hex[:8]}"
        self._clock = clock
        self._wall = wall
        self.hung_after_s = hung_after_s
        self._beat = clock()  # the brain's loop ran at this moment (its heartbeat)
        self._ticks = 0  # renewal rounds (all servers), for tests that wait on the thread
        self._lease_factory = lease_tools
        self._lock = threading.Lock()  # guards the views across the loops
        self._views: dict[str, LeaseView] = {}
        self._stats = RenewalStats()
        self._alarm_book = AlarmBook(latch, on_notice)
        self._alarms = self._alarm_book.by_server  # the same dict (control.lease_child reads it)
        self._renewal = LeaseRenewal(self)
        self._waits = LeaseWaits(self)
        # the brain's loop: waiters, the heartbeat
        self._owner: asyncio.AbstractEventLoop | None = None
        self._renewed: dict[str, asyncio.Event] = {}  # set after each renewal attempt
        self._owner_tasks: set[asyncio.Task[None]] = set()
        # the renewals' loop (the thread's own, or the brain's)
        self._renew_loop: asyncio.AbstractEventLoop | None = None
        self._lease_tools: ToolBackend | None = None
        self._wakes: dict[str, asyncio.Event] = {}
        self._stopping: asyncio.Event | None = None
        # the renewals' process (lease_runner: process): the link, and its mirror here
        self._link = lease_process
        self._mirror = (
            None
            if lease_process is None
            else ProcessMirror(lease_process, latch, self._alarm_book, self)
        )

    # --- lifecycle ----------------------------------------------------------------------
    def motion_servers(self) -> list[str]:
        return [name for name, cfg in self.tools.servers().items() if cfg.motion]

    @property
    def threaded(self) -> bool:
        return self._lease_factory is not None

    @property
    def runner(self) -> Literal["process", "thread", "loop"]:
        """Where the renewals run: a child process, a thread of their own, the brain's loop."""
        if self._link is not None:
            return "process"
        return "thread" if self.threaded else "loop"

    def set_notice_handler(self, handler: NoticeHandler) -> None:
        self._alarm_book.handler = handler

    async def start(self) -> None:
        """Renewals for every motion server, on their own thread when ``lease_tools`` is set;
        the latch's changes and (re)connections are sent at once."""
        self._owner = asyncio.get_running_loop()
        servers = self.motion_servers()
        for server in servers:
            self._views[server] = LeaseView(server)
            self._renewed[server] = asyncio.Event()
        self.latch.add_listener(self._on_latch)
        self.tools.add_connect_listener(self._on_connect)
        ready: asyncio.Future[None] = self._owner.create_future()
        self._beat = self._clock()
        heartbeat = asyncio.create_task(self._heartbeat(), name="lease-heartbeat")
        self._owner_tasks.add(heartbeat)
        heartbeat.add_done_callback(self._owner_tasks.discard)
        timeout_s = START_TIMEOUT_S
        if self._link is not None and self._mirror is not None:
            self._mirror.ready = ready
            timeout_s = PROCESS_START_TIMEOUT_S
            await self._link.start(self._mirror.init_message, self._mirror.receive)
        else:
            self._renewal.launch(servers, ready, threaded=self.threaded)
        async with asyncio.timeout(timeout_s):
            await ready
        logger.info(
            "supervision_started",
            holder=self.holder,
            servers=servers,
            period_s=self.period_s,
            ttl_s=self.ttl_s,
            runner=self.runner,
            pid=self._link.pid if self._link is not None else None,
        )

    async def aclose(self) -> None:
        if self._link is not None:
            await self._link.stop(START_TIMEOUT_S)
        await self._renewal.stop(START_TIMEOUT_S)
        for task in list(self._owner_tasks):
            task.cancel()
        self._alarm_book.cancel()

    async def _heartbeat(self) -> None:
        """The brain's loop shows it runs (and how late it runs: its lag under load)."""
        while True:
            before = self._clock()
            await asyncio.sleep(HEARTBEAT_S)
            self._beat = now = self._clock()
            self._stats.record("loop_lag", max(0.0, now - before - HEARTBEAT_S))
            self._send({"t": "beat"})

    def _send(self, message: dict[str, Any]) -> None:
        """To the renewal process, if the renewals run in one."""
        if self._mirror is not None:
            self._mirror.send(message)

    def brain_hung(self) -> bool:
        """The brain's loop has not run for ``hung_after_s``: a hung brain is a dead one."""
        return self._clock() - self._beat > self.hung_after_s

    async def _renewals(self, servers: list[str], ready: asyncio.Future[None]) -> None:
        await self._renewal.run(servers, ready)

    def _to_owner(self, callback: Callable[..., object], *args: Any) -> None:
        """Run ``callback(*args)`` on the brain's loop (from either loop)."""
        call_soon(self._owner, callback, *args)

    def wake(self, server: str | None = None) -> None:
        """Renew ``server``'s lease (every lease: None) now; thread-safe (the process runner:
        from the brain's loop)."""
        if self._link is not None:
            self._send({"t": "wake", "server": server})
            return
        call_soon(self._renew_loop, self._set_wakes, server)

    def _renew_now(self, server: str) -> None:
        """``server``'s lease connection retries now and its lease is renewed at once."""
        if self._link is not None:
            self._send({"t": "reconnect", "server": server})
            return
        call_soon(self._renew_loop, self._reconnect, server)

    def _set_wakes(self, server: str | None) -> None:
        self._renewal.wake(server)

    async def _on_latch(self, state: LatchState) -> None:
        self.wake()

    async def _on_connect(self, server: str) -> None:
        """The brain's backend (re)connected ``server``: the lease's own connection retries
        now too, and the lease is renewed at once."""
        if server in self._renewed:
            self._renew_now(server)

    def _reconnect(self, server: str) -> None:
        self._renewal.reconnect(server)

    # --- waiting on the leases (on the brain's loop) -------------------------------------
    async def ensure_fresh(self, server: str, timeout_s: float | None = None) -> bool:
        """A fresh lease on ``server`` before a motion call (``LeaseWaits.ensure_fresh``)."""
        return await self._waits.ensure_fresh(server, timeout_s)

    async def ready_for_motion(self, server: str, timeout_s: float) -> bool:
        """A fresh lease, lock open, before a motion call (``LeaseWaits.ready_for_motion``)."""
        return await self._waits.ready_for_motion(server, timeout_s)

    async def wait_lock_open(self, server: str, timeout_s: float) -> bool:
        """Until ``server``'s dead-man lock is open again (``LeaseWaits.wait_lock_open``)."""
        return await self._waits.wait_lock_open(server, timeout_s)

    def lock_open(self, server: str) -> bool:
        return self._waits.lock_open(server)

    async def settle(self, server: str) -> tuple[Literal["lapsed", "latched", "unknown"], float]:
        """After an unconfirmed stop: lapsed or latched (``LeaseWaits.settle``)."""
        return await self._waits.settle(server)

    # --- the view -----------------------------------------------------------------------
    def view(self, server: str) -> LeaseView | None:
        return self._views.get(server)

    def fresh(self, server: str) -> bool:
        """The server holds a lease from us that has not run out."""
        view = self._views.get(server)
        return view is not None and view.fresh_at(self.ttl_s, self._clock())

    def all_fresh(self) -> bool:
        """Every motion server that takes a lease holds a fresh one (a server without the
        ``supervise`` tool is not supervised, and not counted)."""
        return all(
            self.fresh(server)
            for server, view in list(self._views.items())
            if view.state != "unsupported"
        )

    def lapsed_at(self, server: str) -> float | None:
        """Wall time at which ``server``'s lease ran out (None while it may still be fresh,
        or if it never held one)."""
        view = self._views.get(server)
        return None if view is None else view.lapsed_wall(self.ttl_s, self._clock())

    def alarms(self) -> list[dict[str, Any]]:
        """The alarms the motion servers report now (``/api/safety``, readiness)."""
        return self._alarm_book.as_dicts()

    def renewal_stats(self) -> dict[str, list[float]]:
        """Recent renewal timings in seconds: ``gaps``, ``late``, ``loop_lag`` (RenewalStats)."""
        return self._stats.snapshot()

    def summary(self) -> dict[str, Any]:
        now = self._clock()
        return {
            "holder": self.holder,
            "period_s": self.period_s,
            "ttl_s": self.ttl_s,
            "thread": self.threaded,
            "runner": self.runner,
            "servers": {s: v.as_dict(self.ttl_s, now) for s, v in list(self._views.items())},
            "alarms": self.alarms(),
            "renewals": self.renewal_summary(),
        }

    def renewal_summary(self) -> dict[str, Any]:
        """Percentiles (ms) of the recent renewals' gaps and lateness (readiness, benchmarks):
        a gap near the TTL is a lapse a moment away."""
        return self._stats.summary()

    # --- hooks (the child process's renewer overrides them: control.lease_child) --------
    def _own_connections(self) -> bool:
        """The renewals hold connections of their own (not the brain's backend)."""
        return self._lease_tools is not None and self._lease_tools is not self.tools

    def _watches_heartbeat(self) -> bool:
        """The renewals run off the brain's loop, so they must watch that it still runs."""
        return self.threaded

    def _brain_check_now(self, server: str) -> None:
        """The brain's own connection to ``server`` is checked now (on the brain's loop)."""
        self.tools.check_now(server)

    def _record(self, kind: Literal["gaps", "late"], seconds: float) -> None:
        self._stats.record(kind, seconds)

    def _set(self, view: LeaseView, state: LeaseState, detail: str) -> LeaseView:
        before = self._views.get(view.server)
        if before is None or before.state != state:
            log = logger.info if state == "supervised" else logger.warning
            log("supervision_lease", server=view.server, state=state, detail=detail)
        view = dataclasses.replace(view, state=state, detail=detail)
        self._store_view(view)
        return view

    def _renewed_once(self, server: str) -> None:
        event = self._renewed.get(server)
        if event is not None:
            event.set()

    def _take_alarms(self, server: str, alarms: list[SupervisionAlarm]) -> None:
        """Alarms in an answer (on the renewals' side): see ``AlarmBook.take``."""
        news = self._alarm_book.take(server, alarms)
        if news.wake_all:
            self._set_wakes(None)
        if news.tell:
            self._to_owner(self._alarms_seen, server, tuple(alarms))

    def _alarms_seen(self, server: str, alarms: tuple[SupervisionAlarm, ...]) -> None:
        """On the brain's loop: latch now, then the handler; the process carries it on."""
        self._notify(self._alarm_book.latch_now(server, alarms))
        self._send({"t": "alarm_taken"})  # after the latch
        self.wake()

    def _notify(self, notice: SupervisionNotice) -> None:
        self._alarm_book.notify(notice)

    # --- kept in the supervisor's state (control.lease_child's renewer sets them) ---------
    @property
    def _alarm_latch(self) -> str | None:
        """An alarm's reason the renewals carry until the brain's loop has latched it."""
        return self._alarm_book.carried

    @_alarm_latch.setter
    def _alarm_latch(self, reason: str | None) -> None:
        self._alarm_book.carried = reason

    @property
    def _alarm_pending(self) -> bool:
        return self._alarm_book.pending

    @_alarm_pending.setter
    def _alarm_pending(self, pending: bool) -> None:
        self._alarm_book.pending = pending

    # --- the renewals' and the process's news --------------------------------------------
    async def renew(self, server: str) -> LeaseView:
        """Renew ``server``'s lease once (on the renewals' loop)."""
        return await self._renewal.renew(server)

    def _store_view(self, view: LeaseView) -> None:
        with self._lock:
            self._views[view.server] = view

    def _renewal_seen(self, server: str) -> None:
        """The renewal process renewed ``server`` (or tried to)."""
        self._ticks += 1
        self._renewed_once(server)
