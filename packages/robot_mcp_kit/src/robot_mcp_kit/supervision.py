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
- **The lease is the brain's alone** (issue 35): while a lease is fresh, a renewal by another
  holder is an intrusion: it is refused (:class:`LeaseHeldError`, the lease in force stays) and
  raises the ``FOREIGN_HOLDER`` alarm. A new holder is taken without alarm only once the previous
  lease lapsed (a brain restart) or was released. Who may call ``supervise`` at all is the
  tool's business (``supervision_tools``).
- **Alarms** (issue 35): :meth:`Supervision.raise_alarm` (a foreign holder, a second publisher
  on the lock topic, the pose or the map, a goal not ours while latched — the server's graph
  watcher raises them). While any alarm is active the lock is locked, motion is refused with
  ``SUPERVISION_ALARM`` and :meth:`poll` reports an ``alarm`` edge (the watchdog ends what runs
  and cancels every goal below). An alarm stays until its condition is gone (not raised again
  for ``alarm_quiet_s``) **and** the current holder acknowledged it with a renewal carrying
  ``latched=true`` — so a brain sees it, latches, and only an operator's Clear stop moves the
  robot again.
- **Sweep before the lock opens** (issue 35): after every stop (a latch, an alarm, a lapse) the
  lock stays locked and motion refused until the server's watchdog cancelled every goal its
  action servers run or hold (:meth:`sweep_due` / :meth:`mark_swept`), so a goal sent straight
  to the base while latched never runs on Clear stop.

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

import structlog

logger = structlog.get_logger(__name__)

SUPERVISE_TOOL = "supervise"
"""The MCP tool every motion server offers for the brain's lease (``supervision_tools``)."""
SAFETY_STOP_LATCHED = "SAFETY_STOP_LATCHED"
NOT_SUPERVISED = "NOT_SUPERVISED"
INVALID_LEASE = "INVALID_LEASE"
SUPERVISION_ALARM = "SUPERVISION_ALARM"
STOP_CLEARING = "the stop was cleared a moment ago"
"""How a refusal (``SAFETY_STOP_LATCHED``) during the sweep after a clear starts: nothing
moved, and the same call goes through once the sweep is done."""
"""The refusal code while any alarm is active (its detail names the alarms)."""
NOT_PERMITTED = "not_permitted"
"""The tool error code of a ``supervise`` call from anyone but the brain, or by a holder other
than the one whose lease is in force (a stable contract outside checks rely on)."""
FOREIGN_HOLDER = "FOREIGN_HOLDER"
LOCK_TOPIC_SHARED = "LOCK_TOPIC_SHARED"
POSE_TOPIC_SHARED = "POSE_TOPIC_SHARED"
MAP_TOPIC_SHARED = "MAP_TOPIC_SHARED"
FOREIGN_GOAL_CLIENT = "FOREIGN_GOAL_CLIENT"
ALARM_CODES = (
    FOREIGN_HOLDER,
    LOCK_TOPIC_SHARED,
    POSE_TOPIC_SHARED,
    MAP_TOPIC_SHARED,
    FOREIGN_GOAL_CLIENT,
)
DEFAULT_ALARM_QUIET_S = 1.0
"""An alarm's condition counts as gone once nothing raised it again for this long (the graph
watcher re-raises a standing condition every 0.2 s)."""
DEFAULT_MAX_TTL_S = 2.0
"""The longest lease a server grants: a brain that dies is noticed within this at most."""

Lapse = Literal["lapsed", "latched", "alarm"]


class LeaseError(ValueError):
    """A renewal the server refuses (bad holder or TTL); the lease in force is unchanged."""


class LeaseHeldError(LeaseError):
    """A renewal by another holder while a lease is fresh (an intrusion: alarm raised)."""


@dataclass(frozen=True)
class Alarm:
    code: str
    detail: str
    at: float
    """Unix wall time it was first raised."""
    seen: float
    """The supervision clock's time it was last raised (its condition last seen)."""

    def as_dict(self) -> dict[str, Any]:
        return {"code": self.code, "detail": self.detail, "at": round(self.at, 3)}


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
    "alarm": "supervision raised an alarm",
}
"""Why running motion ended, in words the task's failure message carries."""


@dataclass(frozen=True)
class Refusal:
    code: str
    detail: str

    @property
    def lapse(self) -> Lapse:
        if self.code == SUPERVISION_ALARM:
            return "alarm"
        return "latched" if self.code == SAFETY_STOP_LATCHED else "lapsed"

    @property
    def reason(self) -> str:
        """Why motion that ran ended, when it ended for this refusal."""
        if self.code == SUPERVISION_ALARM:
            return f"{LAPSE_REASONS['alarm']}: {self.detail}"
        return LAPSE_REASONS[self.lapse]


class Supervision:
    def __init__(
        self,
        *,
        required: bool = True,
        max_ttl_s: float = DEFAULT_MAX_TTL_S,
        clock: Callable[[], float] = time.monotonic,
        wall: Callable[[], float] = time.time,
        alarm_quiet_s: float = DEFAULT_ALARM_QUIET_S,
        sweeps: bool = False,
    ) -> None:
        """``sweeps``: a watchdog cancels every goal below after each stop
        (``watch_supervision(cancel_all=...)``); until it did, the lock stays locked and motion
        refused. Without it (a server with nothing below, tests of the lease alone) no sweep is
        waited for."""
        if max_ttl_s <= 0 or alarm_quiet_s <= 0:
            raise ValueError("max_ttl_s and alarm_quiet_s must be positive")
        self.required = required
        self.max_ttl_s = max_ttl_s
        self.alarm_quiet_s = alarm_quiet_s
        self.sweeps = sweeps
        self._clock = clock
        self._wall = wall
        self._lock = threading.Lock()
        self._lease: Lease | None = None
        self._alarms: dict[str, Alarm] = {}
        self._moving_allowed = False  # what poll() saw last time, for its edges
        self._latched_since_poll = False  # a latch poll() must report even if cleared since
        self._alarm_since_poll = False  # likewise an alarm raised (and maybe acknowledged) since
        self._stops = 0  # stop edges (latch, alarm, lapse) so far: what a sweep answers
        self._swept = 0  # the stop count the last completed sweep covered
        self._was_fresh = False

    # -- the lease -----------------------------------------------------------------------
    def renew(self, holder: str, ttl_s: float, latched: bool, reason: str = "") -> Lease:
        """Take or renew the lease; returns it. Raises LeaseError for a bad holder or TTL."""
        holder = holder.strip()
        if not holder or len(holder) > 128:
            raise LeaseError("holder must be a non-empty name of at most 128 characters")
        if not math.isfinite(ttl_s) or not 0 < ttl_s <= self.max_ttl_s:
            raise LeaseError(f"ttl_s must be > 0 and <= {self.max_ttl_s:g} s, not {ttl_s!r}")
        now = self._clock()
        lease = Lease(holder, now, float(ttl_s), bool(latched), reason[:200])
        with self._lock:
            held = self._lease
            intruder = held is not None and held.holder != holder and held.fresh(now)
            if not intruder:
                self._note_lapse(now)  # a lapse this renewal ends is a stop all the same
                if lease.latched and not (held is not None and held.latched):
                    self._stops += 1
                self._lease = lease
                self._was_fresh = True
                self._latched_since_poll |= lease.latched
                acknowledged = self._acknowledge(lease, now) if lease.latched else []
        if intruder:
            assert held is not None
            self.raise_alarm(
                FOREIGN_HOLDER,
                f"someone other than the supervising brain ({holder!r}) tried to take over its "
                "lease, so this server locked the robot and refuses motion",
            )
            raise LeaseHeldError(
                f"the lease is held by another supervisor for {held.expires_at - now:.1f} s "
                "more; a new holder is accepted only once it lapsed or was released"
            )
        for alarm in acknowledged:
            logger.info("supervision_alarm_acknowledged", code=alarm.code, holder=holder)
        return lease

    # -- alarms ----------------------------------------------------------------------------
    def raise_alarm(self, code: str, detail: str) -> bool:
        """An intrusion or a standing condition seen now (call again while it lasts). True
        when the alarm is new (then logged ``supervision_alarm``)."""
        now, wall = self._clock(), self._wall()
        with self._lock:
            known = self._alarms.get(code)
            self._alarms[code] = Alarm(code, detail, known.at if known is not None else wall, now)
            if known is None:
                self._stops += 1
                self._alarm_since_poll = True
        if known is None:
            logger.error("supervision_alarm", code=code, detail=detail)
        return known is None

    def _acknowledge(self, lease: Lease, now: float) -> list[Alarm]:
        """(Under the mutex.) A latched renewal by the current holder clears the alarms whose
        condition is gone."""
        gone = [a for a in self._alarms.values() if now - a.seen >= self.alarm_quiet_s]
        for alarm in gone:
            del self._alarms[alarm.code]
        return gone

    def alarms(self) -> list[Alarm]:
        with self._lock:
            return sorted(self._alarms.values(), key=lambda a: a.at)

    # -- the sweep below -------------------------------------------------------------------
    @property
    def stops(self) -> int:
        """How many stop edges (a latch set, an alarm raised, a lapse seen) happened so far."""
        with self._lock:
            return self._stops

    def sweep_due(self, now: float | None = None) -> int | None:
        """The stop count a sweep must now cover — cancel every goal below, then
        :meth:`mark_swept` it — or None when none is owed yet: one is owed after a stop, once
        the stop has ended (the lease fresh and clear, no alarm), i.e. right before the lock
        would open again; goals sent while the stop held are in it."""
        now = self._clock() if now is None else now
        self._observe_lapse(now)
        lease = self.lease
        clear = lease is not None and not lease.latched and (lease.fresh(now) or not self.required)
        if lease is None and not self.required:
            clear = True
        if not clear or self.alarms():
            return None
        with self._lock:
            return self._stops if self.sweeps and self._swept != self._stops else None

    def mark_swept(self, stops: int) -> None:
        """Every goal below was cancelled after ``stops`` stop edges (a later stop needs its
        own sweep)."""
        with self._lock:
            self._swept = max(self._swept, stops)

    def _sweep_pending(self) -> bool:
        with self._lock:
            return self.sweeps and self._swept != self._stops

    def _observe_lapse(self, now: float) -> None:
        with self._lock:
            self._note_lapse(now)

    def _note_lapse(self, now: float) -> None:
        """(Under the mutex.) Count a lapse (a fresh lease running out) as a stop edge once."""
        lease = self._lease
        fresh = lease is not None and lease.fresh(now)
        if self._was_fresh and not fresh:
            self._stops += 1
        self._was_fresh = fresh

    def release(self, holder: str) -> bool:
        """End ``holder``'s lease at once (a brain shutting down cleanly); False if another
        holder's lease is in force (it is left alone)."""
        with self._lock:
            if self._lease is None or self._lease.holder != holder:
                return False
            self._lease = None
            if self._was_fresh:
                self._stops += 1
                self._was_fresh = False
            return True

    @property
    def lease(self) -> Lease | None:
        with self._lock:
            return self._lease

    # -- what it allows ------------------------------------------------------------------
    def refusal(self, now: float | None = None) -> Refusal | None:
        """Why a motion call must be refused now, or None when it may go ahead."""
        now = self._clock() if now is None else now
        self._observe_lapse(now)
        alarms = self.alarms()
        if alarms:
            named = "; ".join(f"{a.code}: {a.detail}" for a in alarms)
            return Refusal(
                SUPERVISION_ALARM,
                f"supervision raised an alarm ({named}): this server refuses every motion until "
                "the supervising brain has latched the stop and the cause is gone, and an "
                "operator clears the stop",
            )
        lease = self.lease
        fresh = lease is not None and lease.fresh(now)
        if lease is not None and lease.latched:  # kept after a lapse: only a clear lifts it
            by = f" ({lease.reason})" if lease.reason else ""
            return Refusal(
                SAFETY_STOP_LATCHED,
                f"a software stop is latched{by}: this server refuses every motion until an "
                "operator clears the stop at the robot's supervisor",
            )
        if (fresh or not self.required) and self._sweep_pending():
            return Refusal(
                SAFETY_STOP_LATCHED,
                f"{STOP_CLEARING}: this server is cancelling every goal its "
                "base runs or holds before it moves again",
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
        if lease is None or not lease.fresh(now) or lease.latched:
            return True
        self._observe_lapse(now)
        return bool(self.alarms()) or self._sweep_pending()

    def poll(self, now: float | None = None) -> Lapse | None:
        """An edge that must end running motion: ``lapsed`` (the lease ran out), ``latched``
        (a fresh lease latched the stop) or ``alarm`` (an alarm was raised); None otherwise.
        Call it periodically."""
        now = self._clock() if now is None else now
        refused = self.refusal(now)
        with self._lock:
            was, self._moving_allowed = self._moving_allowed, refused is None
            latched, self._latched_since_poll = self._latched_since_poll, False
            alarmed, self._alarm_since_poll = self._alarm_since_poll, False
        if not was:
            return None
        if alarmed or (refused is not None and refused.code == SUPERVISION_ALARM):
            return "alarm"
        if latched or (refused is not None and refused.code == SAFETY_STOP_LATCHED):
            return "latched"  # also when the stop was cleared again before this poll
        return None if refused is None else "lapsed"

    def status(self, now: float | None = None) -> dict[str, Any]:
        """What a supervise call answers and readiness shows. ``latched`` is true while the
        lease carries the stop and also while the goals below are still being cancelled after
        one (motion is refused until then); ``alarms``: the active alarms, oldest first."""
        now = self._clock() if now is None else now
        lease = self.lease
        fresh = lease is not None and lease.fresh(now)
        latched = lease is not None and lease.latched
        return {
            "required": self.required,
            "supervised": fresh,
            "holder": lease.holder if lease is not None else None,
            "latched": bool(latched or (fresh and self._sweep_pending())),
            "lock": "locked" if self.locked(now) else "open",
            "lapses_in_s": round(lease.expires_at - now, 3) if lease is not None and fresh else 0.0,
            "alarms": [alarm.as_dict() for alarm in self.alarms()],
        }
