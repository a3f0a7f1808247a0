"""MotionSupervisor: the brain's lease on every ``motion: true`` MCP server (issues 27, 35, 39).

Every ``lease_period_s`` (≤ 1 s) the brain calls each motion server's ``supervise`` tool with
a TTL (``lease_ttl_s``) and its latched software stop; a latch change is sent at once. A server
whose lease lapses — the brain was killed, hung, or cannot reach it — cancels its motion and
locks the robot's base through its dead-man lock (``robot_ros_bridge.dead_man_lock``), so
nothing moves without a live supervisor. This service holds the raw tool backend: the lease is
the brain's own control traffic, never a planner's call (the guard hides ``supervise``).

A busy brain is not a dead one (issue 39): the renewals run on a thread of their own, with its
own event loop and its own MCP connections to the motion servers (``lease_tools``: a backend
built inside that thread, same URLs, transports and credential as the brain's), so a burst of
chat turns, a slow request or a process start on the brain's loop cannot delay them. Between
the two loops: a latch change wakes the renewals at once (``call_soon_threadsafe``), each
renewal's outcome is published as an immutable view under a lock, and waiters on the brain's
loop are woken thread-safely. Without ``lease_tools`` (in-process fakes) the same renewal loop
runs as tasks on the brain's loop. With ``lease_process`` (``control.lease_runner: process``)
the same renewal code runs in a child process instead (``control.lease_child``,
over the pipe of ``control.lease_link``): a thread still waits for the interpreter lock behind
the brain's main thread when the CPU is starved, a process does not; this object then mirrors
the views, timings and alarms the process reports, and sends it the latch and the heartbeat.

Alarms (issue 35): a ``supervise`` answer carrying ``alarms`` (someone else renewed the lease,
published on a lock / pose / map topic, or sent the base a goal) makes the next renewals carry
``latched`` at once (from the renewal thread) and latches the brain's software stop with a reason
naming them; the notice handler halts the mission and tells the operator once (``control.alarms``).
A ``not_permitted`` answer (the server refuses the brain's own lease) is logged and told once.

What it knows feeds what the brain says: a stop that could not reach a motion server is
reported with when that server's supervision lapsed (from then on its base holds itself
stopped), never as "Stopped." about a motion the brain could not reach.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import structlog

from robot_mcp_kit.supervision import SUPERVISE_TOOL
from robot_mcp_kit.tool_errors import parse_tool_error
from robot_voice_chat.control.alarms import (
    BY_SUPERVISION,
    NOT_PERMITTED,
    NoticeHandler,
    SupervisionAlarm,
    SupervisionNotice,
    alarm_reason,
    parse_alarms,
)
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import LatchState
from robot_voice_chat.control.lease_link import LeaseLink
from robot_voice_chat.services.tools.base import ToolBackend

logger = structlog.get_logger(__name__)

LeaseState = Literal["pending", "supervised", "unreachable", "unsupported", "refused"]
START_TIMEOUT_S = 10.0  # the renewal thread's loop and backend come up within this
HEARTBEAT_S = 0.1  # the brain's loop shows it runs this often (the renewal thread reads it)
STATS_SIZE = 4096  # renewal timings kept for readiness and the jitter benchmark
PROCESS_START_TIMEOUT_S = 30.0  # the renewal process imports, connects and says ready


@dataclass(frozen=True)
class LeaseView:
    """The brain's view of one motion server's lease (replaced whole, never mutated: the
    renewal thread publishes it, the brain's loop reads it)."""

    server: str
    state: LeaseState = "pending"
    renewed_at: float | None = None  # monotonic time of the last answered renewal
    renewed_wall: float | None = None  # the same moment, wall clock (for sentences)
    server_latched: bool | None = None  # what the server said in its last answer
    lock: str | None = None  # the server's dead-man lock in its last answer: open / locked
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
            "lock": self.lock,
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
        self._hung = False
        self._ticks = 0  # renewal rounds (all servers), for tests that wait on the thread
        self._lag: deque[float] = deque(maxlen=STATS_SIZE)  # the brain loop's heartbeat lag
        self._lease_factory = lease_tools
        self._on_notice = on_notice
        self._lock = threading.Lock()  # guards the views, alarms and stats across the loops
        self._views: dict[str, LeaseView] = {}
        self._alarms: dict[str, tuple[SupervisionAlarm, ...]] = {}
        self._alarm_latch: str | None = None  # renewals carry latched until the brain latches
        self._alarm_pending = False  # an alarm notice is on its way to the brain's loop
        self._not_permitted: set[str] = set()
        self._gaps: deque[float] = deque(maxlen=STATS_SIZE)  # between answered renewals
        self._late: deque[float] = deque(maxlen=STATS_SIZE)  # periodic renewals, vs schedule
        # the brain's loop: waiters, notices
        self._owner: asyncio.AbstractEventLoop | None = None
        self._renewed: dict[str, asyncio.Event] = {}  # set after each renewal attempt
        self._owner_tasks: set[asyncio.Task[None]] = set()
        # the renewals' loop (the thread's own, or the brain's)
        self._renew_loop: asyncio.AbstractEventLoop | None = None
        self._lease_tools: ToolBackend | None = None
        self._wakes: dict[str, asyncio.Event] = {}
        self._stopping: asyncio.Event | None = None
        self._thread: threading.Thread | None = None
        self._runner: asyncio.Task[None] | None = None
        # the renewals' process (lease_runner: process): the link, what it last heard
        self._link = lease_process
        self._ready: asyncio.Future[None] | None = None
        self._sent_latch: tuple[bool, str] | None = None

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
        self._on_notice = handler

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
        if self._link is not None:
            self._ready = ready
            timeout_s = PROCESS_START_TIMEOUT_S
            await self._link.start(self._child_init, self._from_child)
        elif self._lease_factory is None:
            self._runner = asyncio.create_task(self._renewals(servers, ready), name="leases")
        else:
            self._thread = threading.Thread(
                target=self._thread_main, args=(servers, ready), name="supervision", daemon=True
            )
            self._thread.start()
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
        loop, stopping = self._renew_loop, self._stopping
        if loop is not None and stopping is not None:
            with contextlib.suppress(RuntimeError):  # its loop already ended
                loop.call_soon_threadsafe(stopping.set)
        if self._runner is not None:
            with contextlib.suppress(asyncio.CancelledError):
                await self._runner
            self._runner = None
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, START_TIMEOUT_S)
            if self._thread.is_alive():
                logger.warning("supervision_thread_not_stopped")
            self._thread = None
        for task in list(self._owner_tasks):
            task.cancel()

    async def _heartbeat(self) -> None:
        """The brain's loop shows it runs (and how late it runs: its lag under load)."""
        while True:
            before = self._clock()
            await asyncio.sleep(HEARTBEAT_S)
            self._beat = now = self._clock()
            with self._lock:
                self._lag.append(max(0.0, now - before - HEARTBEAT_S))
            if self._link is not None:
                self._send({"t": "beat"})

    def brain_hung(self) -> bool:
        """The brain's loop has not run for ``hung_after_s``: a hung brain is a dead one."""
        return self._clock() - self._beat > self.hung_after_s

    def _thread_main(self, servers: list[str], ready: asyncio.Future[None]) -> None:
        try:
            asyncio.run(self._renewals(servers, ready))
        except Exception as exc:
            logger.exception("supervision_thread_crashed")
            self._to_owner(_fail, ready, exc)

    async def _renewals(self, servers: list[str], ready: asyncio.Future[None]) -> None:
        """The renewal loop's life: its backend, one renewal task per server, until stopped."""
        self._renew_loop = asyncio.get_running_loop()
        self._stopping = asyncio.Event()
        own = self._lease_factory is not None
        tools = self._lease_factory() if self._lease_factory is not None else self.tools
        self._lease_tools = tools
        if own:
            tools.add_connect_listener(self._on_lease_connect)
            await tools.start()
        self._wakes = {server: asyncio.Event() for server in servers}
        tasks = [
            asyncio.create_task(self._loop(server), name=f"lease-{server}") for server in servers
        ]
        self._to_owner(_succeed, ready)
        try:
            await self._stopping.wait()
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            if own:
                await tools.aclose()

    def _to_owner(self, callback: Callable[..., object], *args: Any) -> None:
        """Run ``callback(*args)`` on the brain's loop (from either loop)."""
        owner = self._owner
        if owner is None or owner.is_closed():
            return
        with contextlib.suppress(RuntimeError):  # the brain's loop is closing
            owner.call_soon_threadsafe(callback, *args)

    def _to_renewals(self, callback: Callable[..., object], *args: Any) -> None:
        loop = self._renew_loop
        if loop is None or loop.is_closed():
            return
        with contextlib.suppress(RuntimeError):
            loop.call_soon_threadsafe(callback, *args)

    def wake(self, server: str | None = None) -> None:
        """Renew ``server``'s lease (every lease: None) now; thread-safe (the process runner:
        from the brain's loop)."""
        if self._link is not None:
            self._send({"t": "wake", "server": server})
            return
        self._to_renewals(self._set_wakes, server)

    def _renew_now(self, server: str) -> None:
        """``server``'s lease connection retries now and its lease is renewed at once."""
        if self._link is not None:
            self._send({"t": "reconnect", "server": server})
            return
        self._to_renewals(self._reconnect, server)

    def _set_wakes(self, server: str | None) -> None:
        for name, event in self._wakes.items():
            if server is None or name == server:
                event.set()

    async def _on_latch(self, state: LatchState) -> None:
        self.wake()

    async def _on_connect(self, server: str) -> None:
        """The brain's backend (re)connected ``server``: the lease's own connection retries
        now too, and the lease is renewed at once."""
        if server in self._renewed:
            self._renew_now(server)

    def _reconnect(self, server: str) -> None:
        if self._lease_tools is not None and self._own_connections():
            self._lease_tools.check_now(server)
        self._set_wakes(server)

    async def _on_lease_connect(self, server: str) -> None:
        """The lease's own connection (re)connected ``server``: renew now, and the brain's
        connection retries now too (the server is back)."""
        self._set_wakes(server)
        self._to_owner(self._brain_check_now, server)

    async def ensure_fresh(self, server: str, timeout_s: float | None = None) -> bool:
        """Before a motion call: a fresh lease on ``server`` (one is asked for at once when
        it has none, e.g. right after it connected), waiting at most ``timeout_s`` (a TTL by
        default). True when fresh; a server not supervised by this brain answers False."""
        view = self._views.get(server)
        if server not in self._renewed or view is None or view.state == "unsupported":
            return False  # not supervised by this brain: nothing to wait for
        if self._current(server):
            return True
        self._renew_now(server)
        renewed = self._renewed[server]
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(self.ttl_s if timeout_s is None else timeout_s):
                while not self._current(server):
                    renewed.clear()
                    await renewed.wait()
        return self._current(server)

    async def ready_for_motion(self, server: str, timeout_s: float) -> bool:
        """Before a motion call: wait (at most ``timeout_s``) until ``server`` holds a fresh
        lease with its lock open. Right after a clear a server first cancels every goal below
        it (issue 35's sweep) and answers ``latched`` meanwhile: a call sent then would be
        refused. A server this brain does not supervise, or a latched brain, answers at once
        (False): the call goes on and meets its refusal, if any."""
        view = self._views.get(server)
        if server not in self._renewed or view is None or view.state == "unsupported":
            return False
        if self.latch.latched:
            return False
        return await self.wait_lock_open(server, timeout_s)

    async def wait_lock_open(self, server: str, timeout_s: float) -> bool:
        """Until ``server`` answered a fresh renewal with its dead-man lock open (the stop
        clear, no alarm): after a lapse, motion may be sent again. False at the timeout."""
        deadline = self._clock() + timeout_s
        while True:
            left = deadline - self._clock()
            if left <= 0:
                return self.lock_open(server)
            if await self.ensure_fresh(server, left) and self.lock_open(server):
                return True
            if self.latch.latched:
                return False
            renewed = self._renewed.get(server)
            if renewed is None:
                return False
            renewed.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(max(0.0, deadline - self._clock())):
                    await renewed.wait()

    def lock_open(self, server: str) -> bool:
        view = self._views.get(server)
        return (
            self._current(server)
            and view is not None
            and view.lock in (None, "open")
            and not self.latch.latched
            and not self._alarms.get(server)
        )

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
            for server, view in list(self._views.items())
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

    def alarms(self) -> list[dict[str, Any]]:
        """The alarms the motion servers report now (``/api/safety``, readiness)."""
        with self._lock:
            return [a.as_dict() for alarms in self._alarms.values() for a in alarms]

    def renewal_stats(self) -> dict[str, list[float]]:
        """Seconds between answered renewals of a server (``gaps``: what a server sees), how
        late each periodic renewal started against its schedule (``late``) and how late the
        brain's own loop ran its heartbeat (``loop_lag``: what a busy brain looks like)."""
        with self._lock:
            return {"gaps": list(self._gaps), "late": list(self._late), "loop_lag": list(self._lag)}

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
        stats = self.renewal_stats()
        out: dict[str, Any] = {"n": len(stats["gaps"])}
        for name, values in stats.items():
            if values:
                ordered = sorted(values)
                for label, q in (("p50", 0.5), ("p99", 0.99)):
                    index = min(len(ordered) - 1, round(q * (len(ordered) - 1)))
                    out[f"{name}_{label}_ms"] = round(ordered[index] * 1000, 1)
                out[f"{name}_max_ms"] = round(ordered[-1] * 1000, 1)
        return out

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
        with self._lock:
            (self._gaps if kind == "gaps" else self._late).append(seconds)

    # --- the renewals' process, seen from the brain's loop ------------------------------
    def _child_init(self) -> dict[str, Any]:
        """What a (re)started renewal process is told first (the link adds the servers)."""
        latch = self.latch.state
        self._sent_latch = (latch.latched, latch.reason or "")
        return {
            "holder": self.holder,
            "period_s": self.period_s,
            "ttl_s": self.ttl_s,
            "hung_after_s": self.hung_after_s,
            "latched": latch.latched,
            "reason": latch.reason or "",
        }

    def _send(self, message: dict[str, Any]) -> None:
        """To the renewal process, the latch first whenever it changed (``engage`` sets it
        before any listener runs: the next renewal carries it, as on the thread)."""
        link = self._link
        if link is None:
            return
        latch = self.latch.state
        now = (latch.latched, latch.reason or "")
        if now != self._sent_latch:
            self._sent_latch = now
            link.send({"t": "latch", "latched": now[0], "reason": now[1]})
        link.send(message)

    def _from_child(self, message: dict[str, Any]) -> None:
        """One message from the renewal process (on the brain's loop)."""
        kind, server = message.get("t"), str(message.get("server", ""))
        if kind == "view":
            view = LeaseView(
                server,
                state=message["state"],
                renewed_at=message.get("renewed_at"),
                renewed_wall=message.get("renewed_wall"),
                server_latched=message.get("server_latched"),
                lock=message.get("lock"),
                detail=str(message.get("detail", "")),
            )
            with self._lock:
                self._views[server] = view
        elif kind == "renewed":
            self._ticks += 1
            self._renewed_once(server)
        elif kind == "stat":
            self._record("gaps" if message.get("k") == "gaps" else "late", float(message["v"]))
        elif kind == "alarms":
            alarms = tuple(parse_alarms(server, message))
            with self._lock:
                if alarms:
                    self._alarms[server] = alarms
                else:
                    self._alarms.pop(server, None)
        elif kind == "alarm_seen":
            self._alarms_seen(server, tuple(parse_alarms(server, message)))
        elif kind == "notice":
            self._notify(SupervisionNotice("not_permitted", server, reason=message["reason"]))
        elif kind == "check_now":
            self.tools.check_now(server)
        elif kind == "ready" and self._ready is not None:
            _succeed(self._ready)
        elif kind == "failed" and self._ready is not None:
            _fail(self._ready, RuntimeError(str(message.get("detail", "failed"))))

    # --- renewing (on the renewals' loop) ------------------------------------------------
    async def _loop(self, server: str) -> None:
        wake = self._wakes[server]
        due: float | None = self._clock()
        while True:
            started = self._clock()
            if due is not None:
                self._record("late", max(0.0, started - due))
            try:
                if self._hung_now():
                    self._set(
                        self._views.get(server) or LeaseView(server),
                        "unreachable",
                        "the brain's loop is hung: the lease is left to lapse",
                    )
                else:
                    await self.renew(server)
            except Exception:  # a renewal loop must outlive any one failure
                logger.exception("supervision_renewal_crashed", server=server)
            self._to_owner(self._renewed_once, server)
            remaining = self.period_s - (self._clock() - started)
            if remaining > 0 and not wake.is_set():
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(remaining):
                        await wake.wait()
            self._ticks += 1
            # a woken renewal is not a scheduled one: it does not count as late or early
            due = None if wake.is_set() else started + self.period_s
            wake.clear()

    def _hung_now(self) -> bool:
        """Renewals run on a thread of their own: they stop while the brain's loop is hung
        (logged once per stretch), so a hung brain halts the robot as a dead one does."""
        hung = self._watches_heartbeat() and self.brain_hung()
        if hung != self._hung:
            self._hung = hung
            if hung:
                logger.error(
                    "supervision_brain_hung",
                    silent_s=round(self._clock() - self._beat, 1),
                    hung_after_s=self.hung_after_s,
                )
            else:
                logger.warning("supervision_brain_responsive")
        return hung

    def _renewed_once(self, server: str) -> None:
        event = self._renewed.get(server)
        if event is not None:
            event.set()

    async def renew(self, server: str) -> LeaseView:
        tools = self._lease_tools or self.tools
        view = self._views.get(server) or LeaseView(server)
        tool = f"{server}.{SUPERVISE_TOOL}"
        if tools.server_states().get(server) != "connected":
            if view.state == "pending" and self._own_connections():
                # the lease's own connections are still coming up (the brain's are up)
                return self._set(view, "pending", f"connecting to {server}")
            return self._set(view, "unreachable", f"{server} is not connected")
        if not tools.has_tool(tool):
            return self._set(view, "unsupported", f"{server} offers no {SUPERVISE_TOOL} tool")
        latch = self.latch.state
        carried = self._alarm_latch  # an alarm the brain's loop has not latched yet
        arguments: dict[str, object] = {
            "holder": self.holder,
            "latched": latch.latched or carried is not None,
            "ttl_s": self.ttl_s,
            "reason": (latch.reason or "") if latch.latched else (carried or ""),
        }
        outcome = await tools.call_tool(tool, arguments, self.ttl_s)
        answered_at, answered_wall = self._clock(), self._wall()
        answer = _json(outcome.text)
        if outcome.is_error or not isinstance(answer, dict):
            refused = parse_tool_error(outcome.text) if outcome.is_error else None
            if refused is not None and refused["error"] == NOT_PERMITTED:
                self._not_permitted_seen(server, refused["detail"])
            state: LeaseState = (
                "refused" if isinstance(answer, dict) or refused is not None else "unreachable"
            )
            if state == "unreachable" and self._own_connections():
                # the brain's own connection may not have noticed yet: a mission told of a
                # lost motion server must not wait for its next health check
                self._to_owner(self._brain_check_now, server)
            return self._set(view, state, outcome.text[:200])
        if server in self._not_permitted:
            self._not_permitted.discard(server)
            logger.info("supervision_permitted", server=server)
        if view.renewed_at is not None:
            self._record("gaps", answered_at - view.renewed_at)
        lock = answer.get("lock")
        view = dataclasses.replace(
            view,
            renewed_at=answered_at,
            renewed_wall=answered_wall,
            server_latched=bool(answer.get("latched")),
            lock=lock if isinstance(lock, str) else None,
        )
        view = self._set(view, "supervised", "")
        self._take_alarms(server, parse_alarms(server, answer))
        return view

    def _set(self, view: LeaseView, state: LeaseState, detail: str) -> LeaseView:
        before = self._views.get(view.server)
        if before is None or before.state != state:
            log = logger.info if state == "supervised" else logger.warning
            log("supervision_lease", server=view.server, state=state, detail=detail)
        view = dataclasses.replace(view, state=state, detail=detail)
        with self._lock:
            self._views[view.server] = view
        return view

    def _take_alarms(self, server: str, alarms: list[SupervisionAlarm]) -> None:
        """Alarms in an answer: the next renewals carry ``latched`` at once (this thread),
        and the brain's loop latches its stop and tells the operator (once per alarm)."""
        with self._lock:
            before = self._alarms.get(server, ())
            if alarms:
                self._alarms[server] = tuple(alarms)
            else:
                self._alarms.pop(server, None)
        if not alarms:
            if before:
                logger.info("supervision_alarms_cleared", server=server)
            return
        latched = self.latch.latched
        if not latched and self._alarm_latch is None:
            self._alarm_latch = alarm_reason(alarms)
            self._set_wakes(None)  # every server hears the latch now, not at its next period
        known = {a.key for a in before}
        if (latched and all(a.key in known for a in alarms)) or self._alarm_pending:
            return
        self._alarm_pending = True
        self._to_owner(self._alarms_seen, server, tuple(alarms))

    def _not_permitted_seen(self, server: str, detail: str) -> None:
        if server in self._not_permitted:
            return
        self._not_permitted.add(server)
        logger.error(
            "supervision_not_permitted",
            server=server,
            detail=detail[:200],
            fix=f"the brain's auth_token for {server} in config/tools/mcp.yaml must be that "
            "server's brain credential",
        )
        notice = SupervisionNotice("not_permitted", server, reason=detail[:200])
        self._to_owner(self._notify, notice)

    # --- on the brain's loop ------------------------------------------------------------
    def _alarms_seen(self, server: str, alarms: tuple[SupervisionAlarm, ...]) -> None:
        """Latch now (no await: nothing the brain sends moves from here), then the handler."""
        self._alarm_pending = False
        reason = alarm_reason(alarms)
        newly = self.latch.engage(BY_SUPERVISION, reason)
        self._alarm_latch = None
        logger.warning(
            "supervision_alarm",
            server=server,
            codes=[a.code for a in alarms],
            details=[a.detail for a in alarms],
            latched_now=newly,
        )
        self._notify(SupervisionNotice("alarms", server, alarms, reason))
        if self._link is not None:
            self._send({"t": "alarm_taken"})  # after the latch: the process carries it on
        self.wake()

    def _notify(self, notice: SupervisionNotice) -> None:
        task = asyncio.get_running_loop().create_task(self._handle(notice))
        self._owner_tasks.add(task)
        task.add_done_callback(self._owner_tasks.discard)

    async def _handle(self, notice: SupervisionNotice) -> None:
        try:
            if self._on_notice is not None:
                await self._on_notice(notice)
            elif notice.kind == "alarms":
                await self.latch.stop(BY_SUPERVISION, notice.reason)
        except Exception:
            logger.exception("supervision_notice_failed", kind=notice.kind, server=notice.server)


def _succeed(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


def _fail(future: asyncio.Future[None], exc: BaseException) -> None:
    if not future.done():
        future.set_exception(exc)


def _json(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return None
