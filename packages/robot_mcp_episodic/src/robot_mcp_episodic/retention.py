"""Retention per kind and the size cap, enforced by the background worker (never on the
ingest path): bags older than ``bags_h`` and index rows older than ``index_d`` go first; then,
while bags + index exceed ``max_mb``, the oldest finished bag, and if no bag is left the
oldest hour of index rows."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import structlog

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.store.base import KINDS, EpisodicStore

logger = structlog.get_logger(__name__)


@dataclass
class Enforced:
    bags_deleted: int = 0
    rows_deleted: dict[str, int] = field(default_factory=dict)


class Janitor:
    def __init__(
        self,
        store: EpisodicStore,
        bags: BagRecorder | None,
        *,
        bags_h: float,
        index_d: float,
        max_mb: float,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self._store = store
        self._bags = bags
        self._bags_s = bags_h * 3600.0
        self._index_s = index_d * 86400.0
        self._max_bytes = int(max_mb * 1024 * 1024)
        self._clock = clock

    def size_bytes(self) -> int:
        bags = self._bags.size_bytes() if self._bags else 0
        return bags + self._store.stats().size_bytes

    def enforce(self) -> Enforced:
        started = time.perf_counter()
        now = self._clock()
        done = Enforced()
        if self._bags is not None:
            done.bags_deleted += len(self._bags.delete_before(now - self._bags_s))
        for kind in KINDS:
            done.rows_deleted[kind] = self._store.delete_before(kind, now - self._index_s)
        while self.size_bytes() > self._max_bytes:
            if self._bags is not None and self._bags.delete_oldest() is not None:
                done.bags_deleted += 1
                continue
            if not self._trim_oldest_hour(done):
                break
        if done.bags_deleted or any(done.rows_deleted.values()):
            logger.info(
                "episodic_retention",
                bags_deleted=done.bags_deleted,
                rows_deleted=done.rows_deleted,
                duration_ms=round((time.perf_counter() - started) * 1000, 2),
            )
        return done

    def _trim_oldest_hour(self, done: Enforced) -> bool:
        stats = self._store.stats()
        oldest = [k.oldest for k in stats.kinds.values() if k.oldest is not None]
        if not oldest:
            return False
        cutoff = min(oldest) + 3600.0
        removed = 0
        for kind in KINDS:
            count = self._store.delete_before(kind, cutoff)
            done.rows_deleted[kind] = done.rows_deleted.get(kind, 0) + count
            removed += count
        self._store.compact()
        return removed > 0
