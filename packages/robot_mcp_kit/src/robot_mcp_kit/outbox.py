"""The poster's durable outbox: a SQLite file of undelivered events and per-task counters.

Synchronous on purpose: :class:`~robot_mcp_kit.poster.EventPoster` runs every call on one
dedicated thread, so the connection is never shared between threads and the event loop
never blocks on disk.

The file is opened in exclusive locking mode, so two live posters can never share one outbox
(the second gets :class:`OutboxLockedError`); the lock dies with the process that held it.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path

from robot_mcp_kit.models import EventType, TaskEvent

DROPPABLE_ORDER: tuple[EventType, ...] = ("progress", "trigger_fired")
"""What may be dropped under pressure, first to last. Everything else is never dropped."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    event_id TEXT NOT NULL UNIQUE,
    task_id TEXT NOT NULL,
    type TEXT NOT NULL,
    seq INTEGER NOT NULL,
    body BLOB NOT NULL,
    created_at REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS events_by_type ON events (type, id);
CREATE TABLE IF NOT EXISTS dead_letters (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    event_id TEXT NOT NULL,
    task_id TEXT NOT NULL,
    type TEXT NOT NULL,
    seq INTEGER NOT NULL,
    body BLOB NOT NULL,
    status INTEGER,
    reason TEXT NOT NULL,
    created_at REAL NOT NULL,
    dead_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS task_seq (
    task_id TEXT PRIMARY KEY,
    next_seq INTEGER NOT NULL,
    updated_at REAL NOT NULL
);
"""


class OutboxError(RuntimeError):
    """The outbox cannot take the event."""


class OutboxFullError(OutboxError):
    """The outbox is at ``max_outbox`` and holds only events that must not be dropped."""


class OutboxLockedError(OutboxError):
    """Another live poster holds this outbox file."""


@dataclass(frozen=True)
class StoredEvent:
    """One undelivered event: the exact bytes to post and what ordering needs."""

    row_id: int
    event_id: str
    task_id: str
    type: str
    seq: int
    body: bytes


@dataclass(frozen=True)
class DeadLetter:
    """An event the receiver refused as malformed (HTTP 400 / 422 ...): kept, not retried."""

    event_id: str
    task_id: str
    type: str
    seq: int
    status: int | None
    reason: str
    dead_at: float
    body: str

    def to_dict(self) -> dict[str, object]:
        return {
            "event_id": self.event_id,
            "task_id": self.task_id,
            "type": self.type,
            "seq": self.seq,
            "status": self.status,
            "reason": self.reason,
            "dead_at": self.dead_at,
            "body": self.body,
        }


def read_dead_letters(db: sqlite3.Connection, limit: int) -> list[DeadLetter]:
    rows = db.execute(
        "SELECT event_id, task_id, type, seq, status, reason, dead_at, body FROM dead_letters "
        "ORDER BY id DESC LIMIT ?",
        (max(0, limit),),
    ).fetchall()
    return [
        DeadLetter(r[0], r[1], r[2], r[3], r[4], r[5], r[6], bytes(r[7]).decode("utf-8", "replace"))
        for r in rows
    ]


@dataclass(frozen=True)
class Appended:
    stored: StoredEvent
    event: TaskEvent
    dropped: tuple[StoredEvent, ...]


class SqliteOutbox:
    def __init__(self, path: Path, *, lock_timeout_s: float = 2.0) -> None:
        self._path = path
        self._lock_timeout_s = lock_timeout_s
        self._conn: sqlite3.Connection | None = None
        self._count = 0

    # -- life cycle ----------------------------------------------------------------------

    def open(self, counter_retention_s: float) -> list[StoredEvent]:
        """Open (creating) the file, take the lock and return every undelivered event in
        outbox order (which is seq order within each task)."""
        self._path.parent.mkdir(parents=True, exist_ok=True)
        conn = sqlite3.connect(
            self._path, timeout=self._lock_timeout_s, isolation_level=None, check_same_thread=False
        )
        try:
            conn.execute("PRAGMA locking_mode=EXCLUSIVE")
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=FULL")
            conn.execute("BEGIN IMMEDIATE")  # takes (and, in exclusive mode, keeps) the lock
            for statement in _SCHEMA.split(";"):
                if statement.strip():
                    conn.execute(statement)
            conn.execute(
                "DELETE FROM task_seq WHERE updated_at < ? "
                "AND task_id NOT IN (SELECT task_id FROM events)",
                (time.time() - counter_retention_s,),
            )
            conn.execute("COMMIT")
            rows = conn.execute(
                "SELECT id, event_id, task_id, type, seq, body FROM events ORDER BY id"
            ).fetchall()
        except sqlite3.OperationalError as exc:
            conn.close()
            if "locked" in str(exc):
                raise OutboxLockedError(
                    f"outbox {self._path} is in use by another poster process"
                ) from exc
            raise
        self._conn = conn
        events = [StoredEvent(r[0], r[1], r[2], r[3], r[4], bytes(r[5])) for r in rows]
        self._count = len(events)
        return events

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    @property
    def count(self) -> int:
        return self._count

    # -- operations ----------------------------------------------------------------------

    def _db(self) -> sqlite3.Connection:
        if self._conn is None:
            raise OutboxError("the outbox is not open")
        return self._conn

    def append(
        self,
        build: Callable[[int], TaskEvent],
        task_id: str,
        max_events: int,
        protected_rows: Collection[int],
    ) -> Appended:
        """Atomically: make room if needed, allocate the task's next seq, store the event.

        ``build(seq)`` returns the event to store. ``protected_rows`` (events being posted
        right now) are never dropped to make room.
        """
        db = self._db()
        db.execute("PRAGMA synchronous=FULL")  # the event is on disk before emit() returns
        db.execute("BEGIN IMMEDIATE")
        try:
            dropped = self._make_room(db, max_events, protected_rows)
            (seq,) = db.execute(
                "INSERT INTO task_seq (task_id, next_seq, updated_at) VALUES (?, 1, ?) "
                "ON CONFLICT(task_id) DO UPDATE SET next_seq = next_seq + 1, "
                "updated_at = excluded.updated_at RETURNING next_seq - 1",
                (task_id, time.time()),
            ).fetchone()
            event = build(int(seq))
            body = event.model_dump_json().encode("utf-8")
            cursor = db.execute(
                "INSERT INTO events (event_id, task_id, type, seq, body, created_at) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (event.event_id, event.task_id, event.type, event.seq, body, time.time()),
            )
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise
        self._count += 1 - len(dropped)
        row_id = cursor.lastrowid
        assert row_id is not None
        stored = StoredEvent(row_id, event.event_id, event.task_id, event.type, event.seq, body)
        return Appended(stored, event, dropped)

    def _make_room(
        self, db: sqlite3.Connection, max_events: int, protected_rows: Collection[int]
    ) -> tuple[StoredEvent, ...]:
        if self._count < max_events:
            return ()
        protected = sorted(protected_rows)
        marks = ",".join("?" * len(protected))
        exclude = f"AND id NOT IN ({marks})" if protected else ""
        for droppable in DROPPABLE_ORDER:
            row = db.execute(
                "SELECT id, event_id, task_id, type, seq, body FROM events "  # noqa: S608
                f"WHERE type = ? {exclude} ORDER BY id LIMIT 1",
                (droppable, *protected),
            ).fetchone()
            if row is not None:
                db.execute("DELETE FROM events WHERE id = ?", (row[0],))
                return (StoredEvent(row[0], row[1], row[2], row[3], row[4], bytes(row[5])),)
        raise OutboxFullError(
            f"outbox holds {self._count} undelivered events (max_outbox={max_events}) and none "
            "of them may be dropped (only progress and trigger_fired are); the receiver has "
            "been unreachable too long"
        )

    def dead_letter(self, row_id: int, status: int | None, reason: str) -> bool:
        """Move an event the receiver refused as malformed to the dead-letter table (kept for
        an operator, never retried); False if it was already gone."""
        db = self._db()
        db.execute("PRAGMA synchronous=FULL")
        db.execute("BEGIN IMMEDIATE")
        try:
            moved = db.execute(
                "INSERT INTO dead_letters "
                "(event_id, task_id, type, seq, body, status, reason, created_at, dead_at) "
                "SELECT event_id, task_id, type, seq, body, ?, ?, created_at, ? "
                "FROM events WHERE id = ?",
                (status, reason[:500], time.time(), row_id),
            ).rowcount
            db.execute("DELETE FROM events WHERE id = ?", (row_id,))
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise
        if moved:
            self._count -= 1
        return moved > 0

    def dead_letters(self, limit: int = 100) -> list[DeadLetter]:
        """The most recent dead letters, newest first."""
        return read_dead_letters(self._db(), limit)

    def dead_letter_count(self) -> int:
        (count,) = self._db().execute("SELECT COUNT(*) FROM dead_letters").fetchone()
        return int(count)

    def remove(self, row_id: int) -> bool:
        """Forget a delivered (or rejected) event; False if it was already gone.

        Not synced on its own: losing a delete to a power cut only means one duplicate
        delivery (same event_id) after restart; the next append syncs it anyway."""
        db = self._db()
        db.execute("PRAGMA synchronous=NORMAL")
        cursor = db.execute("DELETE FROM events WHERE id = ?", (row_id,))
        removed = cursor.rowcount > 0
        if removed:
            self._count -= 1
        return removed
