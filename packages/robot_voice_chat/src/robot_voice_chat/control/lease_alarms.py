"""The supervisor's alarms and notices (issue 35): what the motion servers' ``supervise``
answers report, on both sides of the renewals.

An answer carrying ``alarms`` (someone else renewed the lease, published on a lock / pose / map
topic, or sent the base a goal) makes the next renewals carry ``latched`` at once (from the
renewals' side) and latches the brain's software stop with a reason naming them; the notice
handler halts the mission and tells the operator once (``control.alarms``). A ``not_permitted``
answer (the server refuses the brain's own lease) is logged and told once.
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any, NamedTuple

import structlog

from robot_voice_chat.control.alarms import (
    BY_SUPERVISION,
    NoticeHandler,
    SupervisionAlarm,
    SupervisionNotice,
    alarm_reason,
)
from robot_voice_chat.control.latch import SafetyLatch

logger = structlog.get_logger(__name__)


class AlarmNews(NamedTuple):
    """What the renewals do after taking an answer's alarms."""

    wake_all: bool  # every server hears the latch now, not at its next period
    tell: bool  # the brain's loop latches its stop and tells the operator


class AlarmBook:
    """The alarms each motion server reports now, the latch the renewals carry until the
    brain has latched, the servers refusing the brain's lease, and the notices' handler."""

    def __init__(self, latch: SafetyLatch, on_notice: NoticeHandler | None) -> None:
        self._latch = latch
        self.handler = on_notice
        self._lock = threading.Lock()  # the renewals write, the brain's loop reads
        self.by_server: dict[str, tuple[SupervisionAlarm, ...]] = {}
        self.carried: str | None = None  # renewals carry latched until the brain latches
        self.pending = False  # an alarm notice is on its way to the brain's loop
        self._not_permitted: set[str] = set()
        self._tasks: set[asyncio.Task[None]] = set()

    # --- the renewals' side ---------------------------------------------------------------
    def replace(
        self, server: str, alarms: tuple[SupervisionAlarm, ...]
    ) -> tuple[SupervisionAlarm, ...]:
        """``server``'s alarms are these now (none: cleared); returns the ones before."""
        with self._lock:
            before = self.by_server.get(server, ())
            if alarms:
                self.by_server[server] = alarms
            else:
                self.by_server.pop(server, None)
        return before

    def take(self, server: str, alarms: list[SupervisionAlarm]) -> AlarmNews:
        """Alarms in an answer: the next renewals carry ``latched`` at once, and the brain's
        loop is told (once per alarm)."""
        before = self.replace(server, tuple(alarms))
        if not alarms:
            if before:
                logger.info("supervision_alarms_cleared", server=server)
            return AlarmNews(wake_all=False, tell=False)
        latched = self._latch.latched
        wake_all = False
        if not latched and self.carried is None:
            self.carried = alarm_reason(alarms)
            wake_all = True
        known = {a.key for a in before}
        if (latched and all(a.key in known for a in alarms)) or self.pending:
            return AlarmNews(wake_all=wake_all, tell=False)
        self.pending = True
        return AlarmNews(wake_all=wake_all, tell=True)

    def refused(self, server: str, detail: str) -> SupervisionNotice | None:
        """``server`` refuses the brain's lease: logged, and a notice, once per stretch."""
        if server in self._not_permitted:
            return None
        self._not_permitted.add(server)
        logger.error(
            "supervision_not_permitted",
            server=server,
            detail=detail[:200],
            fix=f"the brain's auth_token for {server} in config/tools/mcp.yaml must be that "
            "server's brain credential",
        )
        return SupervisionNotice("not_permitted", server, reason=detail[:200])

    def permitted(self, server: str) -> None:
        """``server`` took the brain's lease: a refusal, if any, is over."""
        if server in self._not_permitted:
            self._not_permitted.discard(server)
            logger.info("supervision_permitted", server=server)

    # --- the brain's loop -------------------------------------------------------------------
    def latch_now(self, server: str, alarms: tuple[SupervisionAlarm, ...]) -> SupervisionNotice:
        """Latch now (no await: nothing the brain sends moves from here); the notice to tell."""
        self.pending = False
        reason = alarm_reason(alarms)
        newly = self._latch.engage(BY_SUPERVISION, reason)
        self.carried = None
        logger.warning(
            "supervision_alarm",
            server=server,
            codes=[a.code for a in alarms],
            details=[a.detail for a in alarms],
            latched_now=newly,
        )
        return SupervisionNotice("alarms", server, alarms, reason)

    def notify(self, notice: SupervisionNotice) -> None:
        task = asyncio.get_running_loop().create_task(self._handle(notice))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _handle(self, notice: SupervisionNotice) -> None:
        try:
            if self.handler is not None:
                await self.handler(notice)
            elif notice.kind == "alarms":
                await self._latch.stop(BY_SUPERVISION, notice.reason)
        except Exception:
            logger.exception("supervision_notice_failed", kind=notice.kind, server=notice.server)

    def as_dicts(self) -> list[dict[str, Any]]:
        """The alarms the motion servers report now (``/api/safety``, readiness)."""
        with self._lock:
            return [a.as_dict() for alarms in self.by_server.values() for a in alarms]

    def cancel(self) -> None:
        """The notices still being handled are dropped (the supervisor closes)."""
        for task in list(self._tasks):
            task.cancel()
