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

from robot_mcp_kit.mcp_runtime import tool_error
from robot_mcp_kit.supervision import (
    INVALID_LEASE,
    LAPSE_REASONS,
    SUPERVISE_TOOL,
    Lapse,
    LeaseError,
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
        Reserved for the robot's supervisor (the brain), never for planning."""
        try:
            supervision.renew(holder, ttl_s, latched, reason)
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
    read yet (a live brain's lease is not a dead one's)."""
    last: tuple[bool, bool, str | None] | None = None
    locked: bool | None = None
    grace_until = float("-inf")
    deferring = False  # a lapse waits out the grace now: a lag meanwhile never extends it
    while True:
        if publish_lock is not None and supervision.locked() != locked:
            locked = supervision.locked()
            publish_lock()
        edge = supervision.poll()
        refused = supervision.refusal()
        status = supervision.status()
        now = (bool(status["supervised"]), bool(status["latched"]), status["holder"])
        if now != last:
            _log_change(last, now, status)
            last = now
        if not (moving() and (refused is not None or edge == "latched")):
            deferring = False
        else:
            latched = edge == "latched" or (refused is not None and refused.code == LATCHED)
            why: Lapse = "latched" if latched else "lapsed"
            deferring = why == "lapsed" and clock() < grace_until
            if deferring:
                logger.info("supervision_lapse_deferred", grace_s=round(grace_until - clock(), 3))
            else:
                reason = LAPSE_REASONS[why]
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
                logger.warning("supervision_watchdog_starved", overslept_ms=round(overslept * 1000))
            grace_until = clock() + STARVED_GRACE_S


@contextlib.asynccontextmanager
async def supervising(
    supervision: Supervision | None,
    end_motion: Callable[[str], Awaitable[object]],
    moving: Callable[[], bool],
    publish_lock: Callable[[], object] | None = None,
) -> AsyncIterator[None]:
    """``watch_supervision`` for the duration of the block (nothing without ``supervision``);
    on exit the watchdog is cancelled and awaited, so it never acts while the server closes."""
    if supervision is None:
        yield
        return
    watchdog = asyncio.create_task(
        watch_supervision(supervision, end_motion, moving, publish_lock=publish_lock),
        name="supervision",
    )
    try:
        yield
    finally:
        watchdog.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await watchdog


def _log_change(
    before: tuple[bool, bool, str | None] | None,
    after: tuple[bool, bool, str | None],
    status: dict[str, Any],
) -> None:
    supervised, latched, holder = after
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
