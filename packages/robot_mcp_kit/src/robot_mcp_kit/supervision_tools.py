"""The MCP side of supervision, shared by every motion server: the ``supervise`` tool the brain
renews its lease with, and the watchdog that ends motion when the lease lapses or latches.

Adopting supervision in a motion server (navigation does exactly this, see its composition):

    supervision = Supervision(required=settings.supervision_required)
    add_supervise_tool(server, supervision)                   # the brain's lease
    # in each motion tool, before anything moves:
    if (refused := supervision.refusal()) is not None:
        raise tool_error(refused.code, refused.detail)
    # while serving: cancel whatever runs when the lease lapses or latches
    watchdog = asyncio.create_task(watch_supervision(supervision, stop_all, lambda: moving))
    # and the dead-man lock on the robot's twist_mux (robot_ros_bridge.lock_publisher), on a
    # topic of its own: navigation has /robot/supervisor_lock, so e.g. manipulation takes
    # /robot/supervisor_lock/manipulation (+ a twist_mux lock entry and robot-sim's
    # SIM_SUPERVISOR_LOCK_TOPICS); never two publishers on one lock topic
    SupervisorLockPublisher(bridge, supervision.locked, topic="/robot/supervisor_lock/manipulation")

Who may renew (issue 35): only the brain's principal (``caller.BRAIN``, the credential the brain
presents over HTTP) or ``caller.LOCAL`` (the stdio parent or an in-process client: the process
that started this server is its supervisor). ``caller.ANONYMOUS`` — an HTTP server run with
``MCP_AUTH=off``, where any local process could pose as the brain — is refused like the operator's
credential: such a throwaway server runs with its supervision ``off`` or gets a token. A refusal
is the tool error ``not_permitted`` (``{"error": "not_permitted", "detail": ...}``), logged
``supervise_refused`` with the principal and nothing secret; so is a renewal by another holder
while the brain's lease is fresh (that also raises the ``FOREIGN_HOLDER`` alarm).
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import structlog
from mcp.server.mcpserver import MCPServer
from mcp.types import ToolAnnotations

from robot_mcp_kit.caller import BRAIN, LOCAL, current_caller
from robot_mcp_kit.mcp_runtime import tool_error
from robot_mcp_kit.supervision import (
    INVALID_LEASE,
    LAPSE_REASONS,
    NOT_PERMITTED,
    SUPERVISE_TOOL,
    SUPERVISION_ALARM,
    Lapse,
    LeaseError,
    LeaseHeldError,
    Refusal,
    Supervision,
)
from robot_mcp_kit.supervision import (
    SAFETY_STOP_LATCHED as LATCHED,
)

logger = structlog.get_logger(__name__)

SUPERVISES = ToolAnnotations(
    read_only_hint=False, destructive_hint=False, idempotent_hint=True, open_world_hint=False
)
"""Renews the supervising brain's lease (and the latch it carries): the brain's own traffic."""
SUPERVISORS = frozenset({BRAIN, LOCAL})
"""The principals ``supervise`` accepts (see the module doc)."""


def add_supervise_tool(server: MCPServer, supervision: Supervision) -> None:
    """Register ``supervise(holder, latched, ttl_s, reason)`` on ``server``."""

    @server.tool(name=SUPERVISE_TOOL, annotations=SUPERVISES)
    async def supervise(
        holder: str, latched: bool, ttl_s: float = 1.0, reason: str = ""
    ) -> dict[str, Any]:
        """The supervising brain's lease on this motion server; renew it at least every
        second. ``latched``: the brain's software stop is latched (motion is refused and
        what runs is cancelled). The lease lapses ``ttl_s`` seconds after the last renewal;
        then this server cancels its motion and its dead-man lock locks the robot's base.
        Reserved for the robot's supervisor (the brain), never for planning: any other
        credential is refused (``not_permitted``). The answer's ``alarms`` lists what this
        server detected (a foreign holder, a second publisher on its lock topic, ...): while
        any is active it refuses motion and holds its lock locked."""
        principal = current_caller().principal
        if principal not in SUPERVISORS:
            logger.warning("supervise_refused", principal=principal, why="not the brain")
            raise tool_error(
                NOT_PERMITTED,
                f"only the robot's supervising brain may renew this server's lease; this "
                f"call came with the {principal} credential and changed nothing",
            )
        try:
            supervision.renew(holder, ttl_s, latched, reason)
        except LeaseHeldError as exc:
            logger.warning("supervise_refused", principal=principal, why="lease held")
            raise tool_error(NOT_PERMITTED, str(exc)) from exc
        except LeaseError as exc:
            raise tool_error(INVALID_LEASE, str(exc)) from exc
        return supervision.status()


STARVED_GRACE_S = 0.25
"""After this server itself did not run for longer than a period (a starved host: renewals may
be waiting unread in its inbox), a lapse ends motion only once they had this long to be read.
The dead-man lock does not wait: it reads the lease's clock and locks the base meanwhile."""


async def watch_supervision(
    supervision: Supervision,
    end_motion: Callable[[str], Awaitable[object]],
    moving: Callable[[], bool],
    period_s: float = 0.05,
    publish_lock: Callable[[], object] | None = None,
    *,
    cancel_all: Callable[[], Awaitable[bool]] | None = None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], Awaitable[object]] = asyncio.sleep,
) -> None:
    """Until cancelled: every ``period_s``, end running motion (``end_motion(reason)``) while
    ``moving()`` and supervision refuses motion (the lease lapsed, or the stop is latched —
    also a latch cleared again since the last look), and log each change of supervision.
    ``publish_lock``: the lock publisher's ``publish``, called (thread-safe) whenever the lock's
    value changes, so a lock timer held up by a busy ROS executor does not delay it; the wheels
    are locked before the motion is cancelled. A latch ends motion at once; a lapse seen right
    after this process itself was starved waits ``STARVED_GRACE_S`` for the renewals it has not
    read yet (a live brain's lease is not a dead one's).

    ``cancel_all`` (issue 35): cancels every goal the server's action servers run or hold, not
    only its own (True when the servers confirmed). It runs at once on every stop edge (a latch,
    an alarm, a lapse: :attr:`Supervision.stops` grew), and again before the lock may open after
    one (:meth:`Supervision.sweep_due`): until that sweep is confirmed the lock stays locked and
    motion refused. Without it a due sweep is marked done at once (nothing below to cancel)."""
    last: tuple[bool, bool, str | None, tuple[str, ...]] | None = None
    locked: bool | None = None
    grace_until = float("-inf")
    deferring = False  # a lapse waits out the grace now: a lag meanwhile never extends it
    sweeper = _Sweeper(supervision, cancel_all)
    try:
        while True:
            if publish_lock is not None and supervision.locked() != locked:
                locked = supervision.locked()
                publish_lock()
            edge = supervision.poll()
            refused = supervision.refusal()
            status = supervision.status()
            alarms = tuple(str(a["code"]) for a in status["alarms"])
            now = (bool(status["supervised"]), bool(status["latched"]), status["holder"], alarms)
            if now != last:
                _log_change(last, now, status)
                last = now
            sweeper.tick()
            stopping = edge in ("latched", "alarm") or refused is not None
            if not (moving() and stopping):
                deferring = False
            else:
                why = _why(edge, refused)
                deferring = why == "lapsed" and clock() < grace_until
                if deferring:
                    logger.info(
                        "supervision_lapse_deferred", grace_s=round(grace_until - clock(), 3)
                    )
                else:
                    alarmed = why == "alarm" and refused is not None
                    reason = refused.reason if alarmed and refused else LAPSE_REASONS[why]
                    logger.warning("supervision_motion_ended", why=why, reason=reason)
                    try:
                        await end_motion(reason)
                    except Exception:  # the watchdog must outlive a failing stop: it runs again
                        logger.exception("supervision_stop_failed", why=why)
            started = clock()
            await sleep(period_s)
            overslept = clock() - started - period_s
            if overslept > period_s and not deferring:  # not run: its inbox may hold renewals
                if clock() >= grace_until:  # once per starved stretch, not per late tick
                    logger.warning(
                        "supervision_watchdog_starved", overslept_ms=round(overslept * 1000)
                    )
                grace_until = clock() + STARVED_GRACE_S
    finally:
        await sweeper.close()


def _why(edge: Lapse | None, refused: Refusal | None) -> Lapse:
    """Why running motion ends now: an alarm or a latch at once, a lapse maybe after grace."""
    if edge == "alarm" or (refused is not None and refused.code == SUPERVISION_ALARM):
        return "alarm"
    if edge == "latched" or (refused is not None and refused.code == LATCHED):
        return "latched"
    return "lapsed"


class _Sweeper:
    """Runs ``cancel_all`` beside the watchdog (a slow action server never delays a latch)."""

    def __init__(
        self, supervision: Supervision, cancel_all: Callable[[], Awaitable[bool]] | None
    ) -> None:
        self._supervision = supervision
        self._cancel_all = cancel_all
        self._stops = 0  # a stop before the watchdog started is swept at its first look
        self._task: asyncio.Task[None] | None = None
        self._retry_at = float("-inf")

    def tick(self) -> None:
        stops = self._supervision.stops
        due = self._supervision.sweep_due()
        if self._cancel_all is None:
            if due is not None:
                self._supervision.mark_swept(due)
            return
        if self._task is not None and not self._task.done():
            return  # the next look launches what is owed meanwhile
        if stops != self._stops:  # a latch reaches everything below it, at once
            self._stops = stops
            self._task = asyncio.create_task(self._run(stops, "stop"), name="supervision-sweep")
        elif due is not None and time.monotonic() >= self._retry_at:
            self._task = asyncio.create_task(self._run(due, "reopen"), name="supervision-sweep")

    async def _run(self, stops: int, why: str) -> None:
        assert self._cancel_all is not None
        started = time.monotonic()
        try:
            confirmed = await self._cancel_all()
        except Exception:  # the watchdog outlives a failing action server
            logger.exception("supervision_sweep_failed", why=why)
            confirmed = False
        if confirmed and why == "reopen":
            self._supervision.mark_swept(stops)
            self._retry_at = float("-inf")
        elif not confirmed:
            self._retry_at = time.monotonic() + 1.0
        logger.info(
            "supervision_swept" if confirmed else "supervision_sweep_unconfirmed",
            why=why,
            stops=stops,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task


@contextlib.asynccontextmanager
async def supervising(
    supervision: Supervision | None,
    end_motion: Callable[[str], Awaitable[object]],
    moving: Callable[[], bool],
    publish_lock: Callable[[], object] | None = None,
    cancel_all: Callable[[], Awaitable[bool]] | None = None,
) -> AsyncIterator[None]:
    """``watch_supervision`` for the duration of the block (nothing without ``supervision``);
    on exit the watchdog is cancelled and awaited, so it never acts while the server closes."""
    if supervision is None:
        yield
        return
    watchdog = asyncio.create_task(
        watch_supervision(
            supervision, end_motion, moving, publish_lock=publish_lock, cancel_all=cancel_all
        ),
        name="supervision",
    )
    try:
        yield
    finally:
        watchdog.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await watchdog


def _log_change(
    before: tuple[bool, bool, str | None, tuple[str, ...]] | None,
    after: tuple[bool, bool, str | None, tuple[str, ...]],
    status: dict[str, Any],
) -> None:
    supervised, latched, holder, alarms = after
    if before is None:
        logger.info("supervision_state", **status)
    elif supervised and not before[0]:
        logger.info("supervision_granted", holder=holder, latched=latched)
    elif not supervised and before[0]:
        logger.warning("supervision_lapsed", holder=before[2])
    elif holder != before[2]:
        logger.warning("supervision_holder_changed", holder=holder, previous=before[2])
    if before is not None and latched != before[1]:
        logger.warning("supervision_latch", latched=latched, holder=holder)
    if before is not None and alarms != before[3]:
        log = logger.warning if alarms else logger.info
        log("supervision_alarms", alarms=list(alarms), holder=holder)
