"""The renewals themselves (issues 27, 39): one loop per motion server on the renewals' loop
(a thread's own, the brain's, or the child process's), each calling the server's ``supervise``
tool every period with a TTL and the latched stop, at once when woken.

It works through its supervisor's hooks (``_set``, ``_record``, ``_take_alarms``, ...), which
the child process's renewer (``control.lease_child``) overrides to send its news up the pipe.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import threading
from typing import TYPE_CHECKING, Any

import structlog

from robot_mcp_kit.supervision import SUPERVISE_TOOL
from robot_mcp_kit.tool_errors import parse_tool_error
from robot_voice_chat.control.alarms import NOT_PERMITTED, parse_alarms
from robot_voice_chat.control.lease_view import LeaseState, LeaseView
from robot_voice_chat.control.loop_calls import fail, succeed

if TYPE_CHECKING:
    from robot_voice_chat.control.supervisor import MotionSupervisor

logger = structlog.get_logger(__name__)


class LeaseRenewal:
    def __init__(self, host: MotionSupervisor) -> None:
        self._host = host
        self._hung = False  # the brain's loop was hung at the last renewal
        self._thread: threading.Thread | None = None  # the renewals' thread, if threaded
        self._runner: asyncio.Task[None] | None = None  # or their task on the brain's loop

    def launch(self, servers: list[str], ready: asyncio.Future[None], *, threaded: bool) -> None:
        """Start the renewals on a thread of their own, or as a task on this (the brain's)
        loop; ``ready`` is resolved on the brain's loop once they run."""
        if not threaded:
            self._runner = asyncio.create_task(self._host._renewals(servers, ready), name="leases")
            return
        self._thread = threading.Thread(
            target=self._run_in_thread, args=(servers, ready), name="supervision", daemon=True
        )
        self._thread.start()

    async def stop(self, join_timeout_s: float) -> None:
        """The renewals stop, and their thread or task ends (on the brain's loop)."""
        loop, stopping = self._host._renew_loop, self._host._stopping
        if loop is not None and stopping is not None:
            with contextlib.suppress(RuntimeError):  # its loop already ended
                loop.call_soon_threadsafe(stopping.set)
        if self._runner is not None:
            with contextlib.suppress(asyncio.CancelledError):
                await self._runner
            self._runner = None
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, join_timeout_s)
            if self._thread.is_alive():
                logger.warning("supervision_thread_not_stopped")
            self._thread = None

    def _run_in_thread(self, servers: list[str], ready: asyncio.Future[None]) -> None:
        """The renewal thread's life: a loop of its own."""
        try:
            asyncio.run(self._host._renewals(servers, ready))
        except Exception as exc:
            logger.exception("supervision_thread_crashed")
            self._host._to_owner(fail, ready, exc)

    async def run(self, servers: list[str], ready: asyncio.Future[None]) -> None:
        """The renewal loop's life: its backend, one renewal task per server, until stopped."""
        host = self._host
        host._renew_loop = asyncio.get_running_loop()
        host._stopping = stopping = asyncio.Event()
        factory = host._lease_factory
        tools = factory() if factory is not None else host.tools
        host._lease_tools = tools
        if factory is not None:
            tools.add_connect_listener(self._on_lease_connect)
            await tools.start()
        host._wakes = {server: asyncio.Event() for server in servers}
        tasks = [
            asyncio.create_task(self.loop(server, host._wakes[server]), name=f"lease-{server}")
            for server in servers
        ]
        host._to_owner(succeed, ready)
        try:
            await stopping.wait()
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            if factory is not None:
                await tools.aclose()

    def wake(self, server: str | None) -> None:
        """Renew ``server``'s lease (every lease: None) now (on the renewals' loop)."""
        for name, event in self._host._wakes.items():
            if server is None or name == server:
                event.set()

    def reconnect(self, server: str) -> None:
        """``server``'s lease connection retries now and its lease is renewed at once."""
        host = self._host
        if host._lease_tools is not None and host._own_connections():
            host._lease_tools.check_now(server)
        host._set_wakes(server)

    async def _on_lease_connect(self, server: str) -> None:
        """The lease's own connection (re)connected ``server``: renew now, and the brain's
        connection retries now too (the server is back)."""
        self._host._set_wakes(server)
        self._host._to_owner(self._host._brain_check_now, server)

    async def loop(self, server: str, wake: asyncio.Event) -> None:
        host = self._host
        due: float | None = host._clock()
        while True:
            started = host._clock()
            if due is not None:
                host._record("late", max(0.0, started - due))
            try:
                if self._hung_now():
                    host._set(
                        host._views.get(server) or LeaseView(server),
                        "unreachable",
                        "the brain's loop is hung: the lease is left to lapse",
                    )
                else:
                    await host.renew(server)
            except Exception:  # a renewal loop must outlive any one failure
                logger.exception("supervision_renewal_crashed", server=server)
            host._to_owner(host._renewed_once, server)
            remaining = host.period_s - (host._clock() - started)
            if remaining > 0 and not wake.is_set():
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(remaining):
                        await wake.wait()
            host._ticks += 1
            # a woken renewal is not a scheduled one: it does not count as late or early
            due = None if wake.is_set() else started + host.period_s
            wake.clear()

    def _hung_now(self) -> bool:
        """Renewals run off the brain's loop: they stop while that loop is hung (logged once
        per stretch), so a hung brain halts the robot as a dead one does."""
        host = self._host
        hung = host._watches_heartbeat() and host.brain_hung()
        if hung != self._hung:
            self._hung = hung
            if hung:
                logger.error(
                    "supervision_brain_hung",
                    silent_s=round(host._clock() - host._beat, 1),
                    hung_after_s=host.hung_after_s,
                )
            else:
                logger.warning("supervision_brain_responsive")
        return hung

    async def renew(self, server: str) -> LeaseView:
        host = self._host
        tools = host._lease_tools or host.tools
        view = host._views.get(server) or LeaseView(server)
        tool = f"{server}.{SUPERVISE_TOOL}"
        if tools.server_states().get(server) != "connected":
            if view.state == "pending" and host._own_connections():
                # the lease's own connections are still coming up (the brain's are up)
                return host._set(view, "pending", f"connecting to {server}")
            return host._set(view, "unreachable", f"{server} is not connected")
        if not tools.has_tool(tool):
            return host._set(view, "unsupported", f"{server} offers no {SUPERVISE_TOOL} tool")
        latch = host.latch.state
        carried = host._alarm_latch  # an alarm the brain's loop has not latched yet
        arguments: dict[str, object] = {
            "holder": host.holder,
            "latched": latch.latched or carried is not None,
            "ttl_s": host.ttl_s,
            "reason": (latch.reason or "") if latch.latched else (carried or ""),
        }
        outcome = await tools.call_tool(tool, arguments, host.ttl_s)
        answered_at, answered_wall = host._clock(), host._wall()
        answer = _json(outcome.text)
        if outcome.is_error or not isinstance(answer, dict):
            refused = parse_tool_error(outcome.text) if outcome.is_error else None
            if refused is not None and refused["error"] == NOT_PERMITTED:
                notice = host._alarm_book.refused(server, refused["detail"])
                if notice is not None:
                    host._to_owner(host._notify, notice)
            state: LeaseState = (
                "refused" if isinstance(answer, dict) or refused is not None else "unreachable"
            )
            if state == "unreachable" and host._own_connections():
                # the brain's own connection may not have noticed yet: a mission told of a
                # lost motion server must not wait for its next health check
                host._to_owner(host._brain_check_now, server)
            return host._set(view, state, outcome.text[:200])
        host._alarm_book.permitted(server)
        if view.renewed_at is not None:
            host._record("gaps", answered_at - view.renewed_at)
        lock = answer.get("lock")
        view = dataclasses.replace(
            view,
            renewed_at=answered_at,
            renewed_wall=answered_wall,
            server_latched=bool(answer.get("latched")),
            lock=lock if isinstance(lock, str) else None,
        )
        view = host._set(view, "supervised", "")
        host._take_alarms(server, parse_alarms(server, answer))
        return view


def _json(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return None
