"""Supervision of a motion server: the brain's lease and the latch state it carries (issue 27).

Pure and thread-safe (the lock publisher reads it from a ROS executor thread, the MCP tools
and the watchdog from the event loop); the clock is injected, so tests step time by hand.

Rules (the same for every motion server):
- A supervising brain renews a **lease** (``renew``) at least every second with a TTL; the
  lease is *fresh* until ``renewed_at + ttl_s``. Each renewal carries the brain's latched
  software stop (``latched``) and replaces the previous lease, whoever held it.
- The server may move the robot only while a fresh lease says the stop is clear
  (:meth:`Supervision.refusal` is None). A latched lease refuses every motion call with
  ``SAFETY_STOP_LATCHED``; no fresh lease with ``NOT_SUPERVISED``. A server that just started
  has no lease: it accepts no motion before it has heard a fresh lease with the stop clear.
- The dead-man lock (:meth:`Supervision.locked`) is ``False`` only in that same state, so the
  robot's twist_mux passes velocity commands only while a brain supervises and the stop is
  clear. When the server dies the lock goes silent, which twist_mux reads as locked.
- :meth:`Supervision.poll` reports the moments motion must end: the lease lapsed, or a lease
  latched the stop. The server's watchdog then cancels whatever runs. Clearing the stop
  resumes nothing.
- The latch outlives its lease: a brain that latched the stop and then died leaves the server
  refusing motion until a fresh lease clears it (only an operator's Clear stop does that).
- ``required=False`` (a server deliberately run without a brain, e.g. behind a third-party MCP
  host): motion is not refused for want of a lease, but a latched stop still is.

A software stop request and supervision, not an emergency-stop device: the robot's hardware
emergency stop remains required.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

SUPERVISE_TOOL = "supervise"
"""The MCP tool every motion server offers for the brain's lease (``supervision_tools``)."""
SAFETY_STOP_LATCHED = "SAFETY_STOP_LATCHED"
NOT_SUPERVISED = "NOT_SUPERVISED"
INVALID_LEASE = "INVALID_LEASE"
DEFAULT_MAX_TTL_S = 2.0
"""The longest lease a server grants: a brain that dies is noticed within this at most."""

Lapse = Literal["lapsed", "latched"]


class LeaseError(ValueError):
    """A renewal the server refuses (bad holder or TTL); the lease in force is unchanged."""


@dataclass(frozen=True)
class Lease:
    holder: str
    renewed_at: float
    ttl_s: float
    latched: bool
    reason: str = ""

    @property
    def expires_at(self) -> float:
        return self.renewed_at + self.ttl_s

    def fresh(self, now: float) -> bool:
        return now < self.expires_at


LAPSE_REASONS: dict[Lapse, str] = {
    "lapsed": "supervision was lost: the supervising brain stopped renewing its lease",
    "latched": "the software stop was latched",
}
"""Why running motion ended, in words the task's failure message carries."""


@dataclass(frozen=True)
class Refusal:
    code: str
    detail: str

    @property
    def lapse(self) -> Lapse:
        return "latched" if self.code == SAFETY_STOP_LATCHED else "lapsed"

    @property
    def reason(self) -> str:
        """Why motion that ran ended, when it ended for this refusal."""
        return LAPSE_REASONS[self.lapse]


class Supervision:
    def __init__(
        self,
        *,
        required: bool = True,
        max_ttl_s: float = DEFAULT_MAX_TTL_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if max_ttl_s <= 0:
            raise ValueError("max_ttl_s must be positive")
        self.required = required
        self.max_ttl_s = max_ttl_s
        self._clock = clock
        self._lock = threading.Lock()
        self._lease: Lease | None = None
        self._moving_allowed = False  # what poll() saw last time, for its edges
        self._latched_since_poll = False  # a latch poll() must report even if cleared since

    # -- the lease -----------------------------------------------------------------------
    def renew(self, holder: str, ttl_s: float, latched: bool, reason: str = "") -> Lease:
        """Take or renew the lease; returns it. Raises LeaseError for a bad holder or TTL."""
        holder = holder.strip()
        if not holder or len(holder) > 128:
            raise LeaseError("holder must be a non-empty name of at most 128 characters")
        if not math.isfinite(ttl_s) or not 0 < ttl_s <= self.max_ttl_s:
            raise LeaseError(f"ttl_s must be > 0 and <= {self.max_ttl_s:g} s, not {ttl_s!r}")
        lease = Lease(holder, self._clock(), float(ttl_s), bool(latched), reason[:200])
        with self._lock:
            self._lease = lease
            self._latched_since_poll |= lease.latched
        return lease

    def release(self, holder: str) -> bool:
        """End ``holder``'s lease at once (a brain shutting down cleanly); False if another
        holder's lease is in force (it is left alone)."""
        with self._lock:
            if self._lease is None or self._lease.holder != holder:
                return False
            self._lease = None
            return True

    @property
    def lease(self) -> Lease | None:
        with self._lock:
            return self._lease

    # -- what it allows ------------------------------------------------------------------
    def refusal(self, now: float | None = None) -> Refusal | None:
        """Why a motion call must be refused now, or None when it may go ahead."""
        now = self._clock() if now is None else now
        lease = self.lease
        fresh = lease is not None and lease.fresh(now)
        if lease is not None and lease.latched:  # kept after a lapse: only a clear lifts it
            by = f" ({lease.reason})" if lease.reason else ""
            return Refusal(
                SAFETY_STOP_LATCHED,
                f"a software stop is latched{by}: this server refuses every motion until an "
                "operator clears the stop at the robot's supervisor",
            )
        if fresh or not self.required:
            return None
        if lease is None:
            why = "no supervising brain has renewed its lease since this server started"
        else:
            ago = now - lease.expires_at
            why = f"the supervising brain's lease lapsed {ago:.1f} s ago"
        return Refusal(NOT_SUPERVISED, f"{why}; motion is refused until a brain supervises")

    def locked(self, now: float | None = None) -> bool:
        """The dead-man lock's value: False only while a fresh lease says the stop is clear."""
        now = self._clock() if now is None else now
        lease = self.lease
        return lease is None or not lease.fresh(now) or lease.latched

    def poll(self, now: float | None = None) -> Lapse | None:
        """An edge that must end running motion: ``lapsed`` (the lease ran out) or
        ``latched`` (a fresh lease latched the stop); None otherwise. Call it periodically."""
        now = self._clock() if now is None else now
        refused = self.refusal(now)
        with self._lock:
            was, self._moving_allowed = self._moving_allowed, refused is None
            latched, self._latched_since_poll = self._latched_since_poll, False
        if not was:
            return None
        if latched or (refused is not None and refused.code == SAFETY_STOP_LATCHED):
            return "latched"  # also when the stop was cleared again before this poll
        return None if refused is None else "lapsed"

    def status(self, now: float | None = None) -> dict[str, Any]:
        """What a supervise call answers and readiness shows."""
        now = self._clock() if now is None else now
        lease = self.lease
        fresh = lease is not None and lease.fresh(now)
        return {
            "required": self.required,
            "supervised": fresh,
            "holder": lease.holder if lease is not None else None,
            "latched": bool(lease is not None and lease.latched),
            "lock": "locked" if self.locked(now) else "open",
            "lapses_in_s": round(lease.expires_at - now, 3) if lease is not None and fresh else 0.0,
        }
