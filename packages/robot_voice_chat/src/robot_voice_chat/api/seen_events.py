"""Event ids the ingress has handled, kept across restarts (issue 31): a signed event delivered
again after the brain restarted (a poster's retry, a replay within the signature's ±300 s) is a
``duplicate``, as it was before the restart. Bounded: the newest ``api.dedupe_size`` ids."""

from __future__ import annotations

import abc
import asyncio
import sqlite3
import time
from pathlib import Path

from robot_voice_chat.private_files import private_file

_SCHEMA = "CREATE TABLE IF NOT EXISTS seen (event_id TEXT PRIMARY KEY, at REAL NOT NULL)"


class SeenEvents(abc.ABC):
    """Port: where handled event ids outlive the process."""

    @abc.abstractmethod
    async def newest(self, n: int) -> list[str]:
        """The ``n`` most recently handled ids, oldest first."""

    @abc.abstractmethod
    async def add(self, event_id: str) -> None:
        """Record ``event_id`` as handled (and forget the oldest beyond the bound)."""


class MemorySeenEvents(SeenEvents):
    """One process life only (tests of the ingress alone; never a deployment)."""

    def __init__(self) -> None:
        self.ids: list[str] = []

    async def newest(self, n: int) -> list[str]:
        return self.ids[-n:]

    async def add(self, event_id: str) -> None:
        self.ids.append(event_id)


class SqliteSeenEvents(SeenEvents):
    """One small SQLite file (0600) in the brain's data dir; statements off the event loop."""

    def __init__(self, path: Path, keep: int) -> None:
        self.path = path
        self.keep = keep
        self._lock = asyncio.Lock()
        self._ready = False

    def _connect(self) -> sqlite3.Connection:
        if not self._ready:
            private_file(self.path)
        db = sqlite3.connect(self.path, timeout=10)
        if not self._ready:
            db.execute("PRAGMA journal_mode=WAL")
            db.execute(_SCHEMA)
            self._ready = True
        return db

    async def newest(self, n: int) -> list[str]:
        def work() -> list[str]:
            db = self._connect()
            try:
                rows = db.execute(
                    "SELECT event_id FROM seen ORDER BY at DESC, rowid DESC LIMIT ?", (n,)
                ).fetchall()
            finally:
                db.close()
            return [str(r[0]) for r in reversed(rows)]

        async with self._lock:
            return await asyncio.to_thread(work)

    async def add(self, event_id: str) -> None:
        def work() -> None:
            db = self._connect()
            try:
                with db:
                    db.execute(
                        "INSERT OR REPLACE INTO seen (event_id, at) VALUES (?, ?)",
                        (event_id, time.time()),
                    )
                    db.execute(
                        "DELETE FROM seen WHERE rowid NOT IN "
                        "(SELECT rowid FROM seen ORDER BY at DESC, rowid DESC LIMIT ?)",
                        (self.keep,),
                    )
            finally:
                db.close()

        async with self._lock:
            await asyncio.to_thread(work)
