"""What the brain knows of its leases (``control.supervisor``): one immutable view per motion
server, and the renewals' recent timings. The renewals publish both from their own thread or
process; the brain's loop reads them, so each is replaced or appended whole, under a lock."""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from typing import Any, Literal

LeaseState = Literal["pending", "supervised", "unreachable", "unsupported", "refused"]
StatKind = Literal["gaps", "late", "loop_lag"]
STATS_SIZE = 4096  # renewal timings kept for readiness and the jitter benchmark


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

    def fresh_at(self, ttl_s: float, now: float) -> bool:
        """The server holds a lease from us that has not run out at ``now``."""
        lapses = self.lapses_at(ttl_s)
        return self.state == "supervised" and lapses is not None and now < lapses

    def lapsed_wall(self, ttl_s: float, now: float) -> float | None:
        """Wall time at which the lease ran out (None while it may still be fresh at ``now``,
        or if it never held one)."""
        if self.renewed_at is None or self.renewed_wall is None:
            return None
        if now < self.renewed_at + ttl_s:
            return None
        return self.renewed_wall + ttl_s

    def as_dict(self, ttl_s: float, now: float) -> dict[str, Any]:
        return {
            "state": self.state,
            "fresh": self.fresh_at(ttl_s, now),
            "server_latched": self.server_latched,
            "lock": self.lock,
            "detail": self.detail,
        }


class RenewalStats:
    """Seconds between answered renewals of a server (``gaps``: what a server sees), how late
    each periodic renewal started against its schedule (``late``) and how late the brain's own
    loop ran its heartbeat (``loop_lag``: what a busy brain looks like)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()  # appended on the renewals' side, read on the brain's loop
        self._series: dict[StatKind, deque[float]] = {
            kind: deque(maxlen=STATS_SIZE) for kind in ("gaps", "late", "loop_lag")
        }

    def record(self, kind: StatKind, seconds: float) -> None:
        with self._lock:
            self._series[kind].append(seconds)

    def snapshot(self) -> dict[str, list[float]]:
        with self._lock:
            return {kind: list(values) for kind, values in self._series.items()}

    def summary(self) -> dict[str, Any]:
        """Percentiles (ms) of the recent renewals' gaps and lateness (readiness, benchmarks):
        a gap near the TTL is a lapse a moment away."""
        stats = self.snapshot()
        out: dict[str, Any] = {"n": len(stats["gaps"])}
        for name, values in stats.items():
            if values:
                ordered = sorted(values)
                for label, q in (("p50", 0.5), ("p99", 0.99)):
                    index = min(len(ordered) - 1, round(q * (len(ordered) - 1)))
                    out[f"{name}_{label}_ms"] = round(ordered[index] * 1000, 1)
                out[f"{name}_max_ms"] = round(ordered[-1] * 1000, 1)
        return out
