"""The renewals' child process, seen from the brain's loop (issue 39, ``lease_runner: process``).

The process (``control.lease_child``, over the pipe of ``control.lease_link``) renews the leases;
the supervisor mirrors the views, timings and alarms it reports, and sends it the latch and the
heartbeat. A thread still waits for the interpreter lock behind the brain's main thread when
the CPU is starved; a process does not.
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal, Protocol

from robot_voice_chat.control.alarms import SupervisionAlarm, SupervisionNotice, parse_alarms
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.lease_alarms import AlarmBook
from robot_voice_chat.control.lease_link import LeaseLink
from robot_voice_chat.control.lease_view import LeaseView
from robot_voice_chat.control.loop_calls import fail, succeed


class MirrorHost(Protocol):
    """What the process is told, and what its news updates, on the brain's side
    (``MotionSupervisor``)."""

    holder: str
    period_s: float
    ttl_s: float
    hung_after_s: float

    def _store_view(self, view: LeaseView) -> None: ...
    def _renewal_seen(self, server: str) -> None: ...
    def _record(self, kind: Literal["gaps", "late"], seconds: float) -> None: ...
    def _alarms_seen(self, server: str, alarms: tuple[SupervisionAlarm, ...]) -> None: ...
    def _notify(self, notice: SupervisionNotice) -> None: ...
    def _brain_check_now(self, server: str) -> None: ...


class ProcessMirror:
    def __init__(
        self,
        link: LeaseLink,
        latch: SafetyLatch,
        alarms: AlarmBook,
        host: MirrorHost,
    ) -> None:
        self._link = link
        self._latch = latch
        self._alarms = alarms
        self._host = host
        self.ready: asyncio.Future[None] | None = None  # set once the process said ready
        self._sent_latch: tuple[bool, str] | None = None

    def init_message(self) -> dict[str, Any]:
        """What a (re)started renewal process is told first (the link adds the servers)."""
        latch = self._latch.state
        self._sent_latch = (latch.latched, latch.reason or "")
        host = self._host
        return {
            "holder": host.holder,
            "period_s": host.period_s,
            "ttl_s": host.ttl_s,
            "hung_after_s": host.hung_after_s,
            "latched": latch.latched,
            "reason": latch.reason or "",
        }

    def send(self, message: dict[str, Any]) -> None:
        """To the renewal process, the latch first whenever it changed (``engage`` sets it
        before any listener runs: the next renewal carries it, as on the thread)."""
        latch = self._latch.state
        now = (latch.latched, latch.reason or "")
        if now != self._sent_latch:
            self._sent_latch = now
            self._link.send({"t": "latch", "latched": now[0], "reason": now[1]})
        self._link.send(message)

    def receive(self, message: dict[str, Any]) -> None:
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
            self._host._store_view(view)
        elif kind == "renewed":
            self._host._renewal_seen(server)
        elif kind == "stat":
            seconds = float(message["v"])
            self._host._record("gaps" if message.get("k") == "gaps" else "late", seconds)
        elif kind == "alarms":
            self._alarms.replace(server, tuple(parse_alarms(server, message)))
        elif kind == "alarm_seen":
            self._host._alarms_seen(server, tuple(parse_alarms(server, message)))
        elif kind == "notice":
            self._host._notify(SupervisionNotice("not_permitted", server, reason=message["reason"]))
        elif kind == "check_now":
            self._host._brain_check_now(server)
        elif kind == "ready" and self.ready is not None:
            succeed(self.ready)
        elif kind == "failed" and self.ready is not None:
            fail(self.ready, RuntimeError(str(message.get("detail", "failed"))))
