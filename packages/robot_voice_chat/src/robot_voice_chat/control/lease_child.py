"""The lease renewal process (issue 39, ``control.lease_runner: process``): the brain starts it
with ``python -m robot_voice_chat.control.lease_child`` and talks to it over its stdin and
stdout (``control.lease_link`` describes the messages).

It renews every motion server's lease exactly as the brain's own supervisor does on a thread
(the same ``MotionSupervisor`` renewal code: ``ChildRenewer`` only reroutes what would go to
the brain's loop into the pipe), with its own MCP connections. It stops renewing when the
brain's heartbeat has been silent ``hung_after_s`` (a hung brain halts the robot) and exits at
once when its stdin reaches EOF (a killed brain halts the robot within the TTL).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import sys
from collections.abc import Callable
from typing import Any, Literal

import structlog

from robot_voice_chat.control.alarms import SupervisionAlarm, SupervisionNotice
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import LatchState, MemoryLatchStore
from robot_voice_chat.control.supervisor import LeaseState, LeaseView, MotionSupervisor
from robot_voice_chat.services.tools.base import ToolBackend

logger = structlog.get_logger(__name__)

Message = dict[str, Any]
NICE = -5  # a little ahead of the brain when the system permits it (never relied on)


class MirrorLatch(SafetyLatch):
    """The brain's latch as last heard over the pipe (the brain persists the real one)."""

    def __init__(self) -> None:
        super().__init__(MemoryLatchStore())

    def mirror(self, latched: bool, reason: str) -> bool:
        """Take the brain's latch; True when it changed."""
        if (self._state.latched, self._state.reason or "") == (latched, reason):
            return False
        self._state = (
            LatchState(latched=True, by="brain", reason=reason) if latched else LatchState()
        )
        return True


class ChildRenewer(MotionSupervisor):
    """The renewal side of ``MotionSupervisor``, its news to the brain sent as messages."""

    def __init__(
        self,
        tools: ToolBackend,
        latch: MirrorLatch,
        send: Callable[[Message], None],
        **kwargs: Any,
    ) -> None:
        super().__init__(tools, latch, lease_tools=lambda: tools, **kwargs)
        self.mirror = latch
        self._send_up = send
        self._task: asyncio.Task[None] | None = None

    async def run(self) -> None:
        """Start renewing (``ready`` once the connections are being made); returns at once."""
        self._owner = asyncio.get_running_loop()
        servers = self.motion_servers()
        for server in servers:
            self._views[server] = LeaseView(server)
        ready: asyncio.Future[None] = self._owner.create_future()
        self._task = asyncio.create_task(self._renewals(servers, ready), name="leases")
        await ready
        self._send_up({"t": "ready", "servers": servers})

    def stopped(self) -> bool:
        """The brain asked this process to stop."""
        return self._stopping is not None and self._stopping.is_set()

    async def finish(self) -> None:
        """Stop renewing and close the connections."""
        if self._stopping is not None:
            self._stopping.set()
        if self._task is not None:
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    def handle(self, message: Message) -> None:
        """One message from the brain (on this process's loop)."""
        kind = message.get("t")
        if kind == "beat":
            self._beat = self._clock()
        elif kind == "latch":
            latched = bool(message.get("latched"))
            if self.mirror.mirror(latched, str(message.get("reason", ""))):
                if latched:
                    self._alarm_latch = None  # the brain's latch carries it from now on
                self._set_wakes(None)
        elif kind == "wake":
            server = message.get("server")
            self._set_wakes(server if isinstance(server, str) else None)
        elif kind == "reconnect":
            self._reconnect(str(message.get("server")))
        elif kind == "alarm_taken":
            self._alarm_pending = False
            self._alarm_latch = None
        elif kind == "stop" and self._stopping is not None:
            self._stopping.set()

    # --- MotionSupervisor's hooks: what went to the brain's loop goes up the pipe -------
    def _own_connections(self) -> bool:
        return True

    def _watches_heartbeat(self) -> bool:
        return True

    def _brain_check_now(self, server: str) -> None:
        self._send_up({"t": "check_now", "server": server})

    def _record(self, kind: Literal["gaps", "late"], seconds: float) -> None:
        self._send_up({"t": "stat", "k": kind, "v": round(seconds, 6)})

    def _set(self, view: LeaseView, state: LeaseState, detail: str) -> LeaseView:
        view = super()._set(view, state, detail)
        self._send_up(
            {
                "t": "view",
                "server": view.server,
                "state": view.state,
                "renewed_at": view.renewed_at,
                "renewed_wall": view.renewed_wall,
                "server_latched": view.server_latched,
                "lock": view.lock,
                "detail": view.detail,
            }
        )
        return view

    def _renewed_once(self, server: str) -> None:
        self._send_up({"t": "renewed", "server": server})

    def _take_alarms(self, server: str, alarms: list[SupervisionAlarm]) -> None:
        before = self._alarms.get(server, ())
        super()._take_alarms(server, alarms)
        if tuple(alarms) != tuple(before):
            self._send_up({"t": "alarms", "server": server, "alarms": _raw(alarms)})

    def _alarms_seen(self, server: str, alarms: tuple[SupervisionAlarm, ...]) -> None:
        # the brain latches and tells; until it says alarm_taken, renewals carry latched
        self._send_up({"t": "alarm_seen", "server": server, "alarms": _raw(alarms)})

    def _notify(self, notice: SupervisionNotice) -> None:
        self._send_up({"t": "notice", "server": notice.server, "reason": notice.reason})


def _raw(alarms: list[SupervisionAlarm] | tuple[SupervisionAlarm, ...]) -> list[Message]:
    return [{"code": a.code, "detail": a.detail, "at": a.at} for a in alarms]


def build(init: Message, send: Callable[[Message], None]) -> ChildRenewer:
    """The renewer an ``init`` message describes, with its own MCP connections."""
    from robot_voice_chat.services.tools.mcp import McpToolBackend
    from robot_voice_chat.settings import McpServerConfig

    servers = [McpServerConfig.model_validate(s) for s in init["servers"]]
    backend = dict(init.get("backend", {}))
    if "quiet_tools" in backend:
        backend["quiet_tools"] = frozenset(backend["quiet_tools"])
    tools = McpToolBackend(servers, **backend)
    latch = MirrorLatch()
    latch.mirror(bool(init.get("latched")), str(init.get("reason", "")))
    return ChildRenewer(
        tools,
        latch,
        send,
        period_s=float(init["period_s"]),
        ttl_s=float(init["ttl_s"]),
        holder=str(init["holder"]),
        hung_after_s=float(init["hung_after_s"]),
    )


async def serve() -> None:
    """The process's life: the pipe on stdin/stdout; EOF on stdin ends it at once."""
    loop = asyncio.get_running_loop()
    up_fd = os.dup(sys.stdout.fileno())
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # a stray print never garbles the pipe
    up, _ = await loop.connect_write_pipe(asyncio.Protocol, os.fdopen(up_fd, "wb", buffering=0))

    def send(message: Message) -> None:
        if not up.is_closing():
            up.write(json.dumps(message, separators=(",", ":")).encode() + b"\n")

    reader = asyncio.StreamReader(limit=1 << 20)
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)

    async def line() -> Message | None:
        raw = await reader.readline()
        if not raw:
            logger.warning("supervision_process_orphaned", detail="the brain's pipe closed")
            os._exit(0)  # the brain is gone: no renewal after this line
        try:
            message = json.loads(raw)
        except ValueError:
            return None
        return message if isinstance(message, dict) else None

    init = await line()
    if init is None or init.get("t") != "init":
        send({"t": "failed", "detail": "no init message"})
        return
    try:
        renewer = build(init, send)
        await renewer.run()
    except Exception as exc:
        logger.exception("supervision_process_failed")
        send({"t": "failed", "detail": str(exc)[:200]})
        return
    while not renewer.stopped():
        message = await line()
        if message is not None:
            renewer.handle(message)
    await renewer.finish()


def main() -> None:
    from robot_voice_chat.logging import configure_logging
    from robot_voice_chat.settings import EnvSettings

    env = EnvSettings()
    configure_logging(env.log_level, env.log_format)
    with contextlib.suppress(OSError):
        os.nice(NICE)  # only where permitted (CAP_SYS_NICE); nothing relies on it
    asyncio.run(serve())


if __name__ == "__main__":
    main()
