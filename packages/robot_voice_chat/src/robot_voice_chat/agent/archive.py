"""Missions that outlive the process (issue 13 item 20): the snapshot of every mission and its
event log in ``mission_event`` shape, in SQLite in the brain's data directory."""

from __future__ import annotations

import abc
import asyncio
import json
import sqlite3
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, fields
from datetime import datetime
from pathlib import Path
from typing import Any

from robot_voice_chat.agent.mission import ACTIVE_STATES, Mission, PlanStep
from robot_voice_chat.private_files import private_file
from robot_voice_chat.services.llm.base import Usage
from robot_voice_chat.socket_events import MissionEventLine

_SCHEMA = """
CREATE TABLE IF NOT EXISTS mission (
    id TEXT PRIMARY KEY, created_at TEXT NOT NULL, body TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS mission_event (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, mission_id TEXT NOT NULL, body TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS mission_event_by_mission ON mission_event (mission_id, seq);
"""


class MissionArchive(abc.ABC):
    """Port: where finished and running missions are kept across restarts."""

    @abc.abstractmethod
    async def save(self, mission: Mission) -> None:
        """Insert or replace the mission's snapshot."""

    @abc.abstractmethod
    async def append_event(self, line: MissionEventLine) -> None: ...

    @abc.abstractmethod
    async def load(self, mission_id: str) -> Mission | None: ...

    @abc.abstractmethod
    async def events(self, mission_id: str) -> list[MissionEventLine]: ...

    @abc.abstractmethod
    async def recent(self, limit: int) -> list[Mission]: ...

    @abc.abstractmethod
    async def live(self) -> list[Mission]:
        """Missions saved in an active state (after a crash: interrupted ones)."""


class SqliteMissionArchive(MissionArchive):
    """One file, never touched on the event loop (issue 39: a burst of chat turns queued one
    connection, commit and close per mission log line, and a mission's page waited behind them).

    One long-lived connection per worker thread: writes go to one writer thread, and the
    writes waiting meanwhile are committed together (one transaction, one fsync; each caller
    returns once its own write is committed); reads run on a reader thread of their own, so
    a page never waits behind the writes (WAL: readers see every committed write)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._ready = False
        self._init = threading.Lock()
        self._local = threading.local()
        self._writer = ThreadPoolExecutor(1, thread_name_prefix="archive-write")
        self._reader = ThreadPoolExecutor(1, thread_name_prefix="archive-read")
        self._pending: list[tuple[str, tuple[Any, ...], asyncio.Future[None]]] = []
        self._flushing: asyncio.Task[None] | None = None

    def _db(self) -> sqlite3.Connection:
        db: sqlite3.Connection | None = getattr(self._local, "db", None)
        if db is None:
            with self._init:
                if not self._ready:
                    private_file(self.path)  # 0600 (SQLite gives its -wal/-shm the same mode)
                db = sqlite3.connect(self.path, timeout=10)
                if not self._ready:
                    db.execute("PRAGMA journal_mode=WAL")
                    db.executescript(_SCHEMA)
                    self._ready = True
            self._local.db = db
        return db

    async def _read(self, sql: str, args: tuple[Any, ...]) -> list[tuple[Any, ...]]:
        def work() -> list[tuple[Any, ...]]:
            return self._db().execute(sql, args).fetchall()

        return await asyncio.get_running_loop().run_in_executor(self._reader, work)

    async def _write(self, sql: str, args: tuple[Any, ...]) -> None:
        """Returns once committed (with the writes that waited beside it)."""
        done: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._pending.append((sql, args, done))
        if self._flushing is None or self._flushing.done():
            self._flushing = asyncio.create_task(self._flush())
        await done

    async def _flush(self) -> None:
        loop = asyncio.get_running_loop()
        while self._pending:
            batch, self._pending = self._pending, []
            statements = [(sql, args) for sql, args, _ in batch]
            errors = await loop.run_in_executor(self._writer, self._commit, statements)
            for (_, _, done), error in zip(batch, errors, strict=True):
                if done.done():
                    continue
                if error is None:
                    done.set_result(None)
                else:
                    done.set_exception(error)

    def _commit(self, statements: list[tuple[str, tuple[Any, ...]]]) -> list[Exception | None]:
        """All in one transaction; if that fails, each alone (one bad write fails only itself)."""
        db = self._db()
        try:
            with db:
                for sql, args in statements:
                    db.execute(sql, args)
            return [None] * len(statements)
        except sqlite3.Error:
            if len(statements) == 1:
                raise
        errors: list[Exception | None] = []
        for sql, args in statements:
            try:
                with db:
                    db.execute(sql, args)
                errors.append(None)
            except sqlite3.Error as exc:
                errors.append(exc)
        return errors

    async def save(self, mission: Mission) -> None:
        await self._write(
            "INSERT OR REPLACE INTO mission (id, created_at, body) VALUES (?, ?, ?)",
            (mission.id, mission.created_at.isoformat(), json.dumps(to_record(mission))),
        )

    async def append_event(self, line: MissionEventLine) -> None:
        await self._write(
            "INSERT INTO mission_event (mission_id, body) VALUES (?, ?)",
            (line.mission_id, line.model_dump_json()),
        )

    async def load(self, mission_id: str) -> Mission | None:
        rows = await self._read("SELECT body FROM mission WHERE id = ?", (mission_id,))
        return from_record(json.loads(rows[0][0])) if rows else None

    async def events(self, mission_id: str) -> list[MissionEventLine]:
        rows = await self._read(
            "SELECT body FROM mission_event WHERE mission_id = ? ORDER BY seq", (mission_id,)
        )
        return [MissionEventLine.model_validate_json(r[0]) for r in rows]

    async def recent(self, limit: int) -> list[Mission]:
        rows = await self._read(
            "SELECT body FROM mission ORDER BY created_at DESC LIMIT ?", (limit,)
        )
        return [from_record(json.loads(r[0])) for r in rows]

    async def live(self) -> list[Mission]:
        states = sorted(ACTIVE_STATES)
        marks = ", ".join("?" * len(states))
        rows = await self._read(
            f"SELECT body FROM mission WHERE json_extract(body, '$.state') IN ({marks}) "  # noqa: S608 (placeholders only)
            "ORDER BY created_at",
            tuple(states),
        )
        return [from_record(json.loads(r[0])) for r in rows]


def _iso(value: datetime | None) -> str | None:
    return value.isoformat() if value is not None else None


def _dt(value: str | None) -> datetime | None:
    return datetime.fromisoformat(value) if value else None


def to_record(mission: Mission) -> dict[str, Any]:
    data = asdict(mission)
    data["created_at"] = _iso(mission.created_at)
    data["ended_at"] = _iso(mission.ended_at)
    data["usage"] = mission.usage.model_dump()
    data["steps"] = [
        {**asdict(s), "started_at": _iso(s.started_at), "ended_at": _iso(s.ended_at)}
        for s in mission.steps
    ]
    return data


def _known(cls: type[Any], data: dict[str, Any]) -> dict[str, Any]:
    """Fields this version knows (records written by another version still load)."""
    names = {f.name for f in fields(cls)}
    return {k: v for k, v in data.items() if k in names}


def from_record(data: dict[str, Any]) -> Mission:
    steps = [
        PlanStep(
            **{
                **_known(PlanStep, s),
                "started_at": _dt(s.get("started_at")),
                "ended_at": _dt(s.get("ended_at")),
            }
        )
        for s in data["steps"]
    ]
    created = _dt(data["created_at"])
    assert created is not None
    return Mission(
        **{
            **_known(Mission, data),
            "steps": steps,
            "created_at": created,
            "ended_at": _dt(data.get("ended_at")),
            "usage": Usage.model_validate(data.get("usage") or {}),
        }
    )
