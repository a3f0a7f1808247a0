"""Shared fixtures: stores of both kinds (SQLite file, fresh database on the throwaway
PostgreSQL), the office map's places and a controllable clock."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from robot_mcp_episodic.config import default_map_file
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.store.base import EpisodicStore
from robot_mcp_episodic.store.postgres import PostgresEpisodicStore
from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore

StoreFactory = Callable[..., EpisodicStore]
T0 = 1_790_000_000.0  # 2026-09-21T13:46:40Z, a fixed start for deterministic episodes


class Clock:
    def __init__(self, now: float = T0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> float:
        self.now += seconds
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def places() -> Places:
    return Places.from_yaml(default_map_file())


@pytest.fixture(params=["sqlite", "postgres"])
def store_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def open_store(
    store_kind: str, request: pytest.FixtureRequest, tmp_path: Path
) -> Iterator[StoreFactory]:
    """``open_store(robot_id="robot-1")`` on one shared database of the parametrized kind."""
    opened: list[EpisodicStore] = []
    dsn = request.getfixturevalue("postgres_dsn") if store_kind == "postgres" else ""

    def factory(robot_id: str = "robot-1") -> EpisodicStore:
        store: EpisodicStore
        if store_kind == "postgres":
            store = PostgresEpisodicStore(dsn, robot_id)
        else:
            store = SqliteEpisodicStore(tmp_path / "episodic.sqlite3", robot_id)
        opened.append(store)
        return store

    try:
        yield factory
    finally:
        for store in opened:
            store.close()


@pytest.fixture
def sqlite_store(tmp_path: Path) -> Iterator[EpisodicStore]:
    store = SqliteEpisodicStore(tmp_path / "episodic.sqlite3", "robot-1")
    try:
        yield store
    finally:
        store.close()
