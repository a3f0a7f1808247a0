"""Waiting on the leases, on the brain's loop (issues 27, 35): before a motion call, a fresh
lease with the server's dead-man lock open; after a stop a server did not confirm, until its
lease has surely lapsed or it heard the latched stop.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from robot_voice_chat.control.supervisor import MotionSupervisor


class LeaseWaits:
    def __init__(self, host: MotionSupervisor) -> None:
        self._host = host

    async def ensure_fresh(self, server: str, timeout_s: float | None) -> bool:
        """Before a motion call: a fresh lease on ``server`` (one is asked for at once when
        it has none, e.g. right after it connected), waiting at most ``timeout_s`` (a TTL by
        default). True when fresh; a server not supervised by this brain answers False."""
        host = self._host
        if not self._supervises(server):
            return False  # nothing to wait for
        if self._current(server):
            return True
        host._renew_now(server)
        renewed = host._renewed[server]
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(host.ttl_s if timeout_s is None else timeout_s):
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
        if not self._supervises(server) or self._host.latch.latched:
            return False
        return await self.wait_lock_open(server, timeout_s)

    def _supervises(self, server: str) -> bool:
        """This brain renews a lease on ``server``: a motion server offering ``supervise``."""
        host = self._host
        view = host._views.get(server)
        return server in host._renewed and view is not None and view.state != "unsupported"

    async def wait_lock_open(self, server: str, timeout_s: float) -> bool:
        """Until ``server`` answered a fresh renewal with its dead-man lock open (the stop
        clear, no alarm): after a lapse, motion may be sent again. False at the timeout."""
        host = self._host
        deadline = host._clock() + timeout_s
        while True:
            left = deadline - host._clock()
            if left <= 0:
                return self.lock_open(server)
            if await self.ensure_fresh(server, left) and self.lock_open(server):
                return True
            if host.latch.latched:
                return False
            renewed = host._renewed.get(server)
            if renewed is None:
                return False
            renewed.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(max(0.0, deadline - host._clock())):
                    await renewed.wait()

    def lock_open(self, server: str) -> bool:
        host = self._host
        view = host._views.get(server)
        return (
            self._current(server)
            and view is not None
            and view.lock in (None, "open")
            and not host.latch.latched
            and not host._alarms.get(server)
        )

    def _current(self, server: str) -> bool:
        """Fresh, and the server has heard the brain's latch as it is now (a motion call right
        after the operator cleared the stop must not meet the server's old latch)."""
        host = self._host
        view = host._views.get(server)
        return (
            host.fresh(server)
            and view is not None
            and view.server_latched is not None
            and view.server_latched == host.latch.latched
        )

    async def settle(self, server: str) -> tuple[Literal["lapsed", "latched", "unknown"], float]:
        """After a stop that ``server`` did not confirm: wait (at most a TTL and a period)
        until either its lease has surely run out (``lapsed``, with the wall time it did:
        from then on its base holds itself stopped) or it answered a renewal carrying the
        latched stop (``latched``); ``unknown`` if neither (it never held a lease)."""
        host = self._host
        deadline = host._clock() + host.ttl_s + host.period_s
        host.wake()
        while True:
            view = host._views.get(server)
            lapsed = host.lapsed_at(server)
            if lapsed is not None:
                return "lapsed", lapsed
            if view is None or view.renewed_at is None:
                return "unknown", 0.0
            if host.fresh(server) and view.server_latched and host.latch.latched:
                return "latched", 0.0
            if host._clock() >= deadline:
                return "unknown", 0.0
            await asyncio.sleep(host.period_s / 4)
