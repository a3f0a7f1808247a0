"""The tables declared with SQLAlchemy Core are the ones the hand-written DDL made: an index
written before opens as it is (nothing is migrated or dropped), and a new one has the same
columns and indexes."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

import psycopg

from robot_mcp_episodic.store.base import EpisodicStore, Note, PoseSample, Sighting, Visit
from robot_mcp_episodic.store.postgres import PostgresEpisodicStore
from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore

T = 1_790_000_000.0

# The schemas as the adapters wrote them before their tables were declared with Core.
SQLITE_BEFORE = """
CREATE TABLE IF NOT EXISTS sightings (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, skill TEXT NOT NULL,
    label TEXT NOT NULL, first_seen REAL NOT NULL, last_seen REAL NOT NULL,
    count INTEGER NOT NULL, best_score REAL NOT NULL, box TEXT, x REAL, y REAL, yaw REAL,
    place TEXT, absent_since REAL
);
CREATE INDEX IF NOT EXISTS sightings_by_time ON sightings (robot_id, last_seen);
CREATE INDEX IF NOT EXISTS sightings_by_label ON sightings (robot_id, label, last_seen);
CREATE INDEX IF NOT EXISTS sightings_by_start ON sightings (robot_id, first_seen);
CREATE TABLE IF NOT EXISTS poses (
    id INTEGER PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, t REAL NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, yaw REAL NOT NULL, place TEXT
);
CREATE INDEX IF NOT EXISTS poses_by_time ON poses (robot_id, t);
CREATE TABLE IF NOT EXISTS notes (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, t REAL NOT NULL,
    kind TEXT NOT NULL, text TEXT NOT NULL, mission_id TEXT, place TEXT
);
CREATE INDEX IF NOT EXISTS notes_by_time ON notes (robot_id, t);
CREATE VIRTUAL TABLE IF NOT EXISTS notes_fts USING fts5 (
    text, content='notes', content_rowid='rowid', tokenize='porter unicode61'
);
CREATE TRIGGER IF NOT EXISTS notes_ai AFTER INSERT ON notes BEGIN
    INSERT INTO notes_fts (rowid, text) VALUES (new.rowid, new.text);
END;
CREATE TRIGGER IF NOT EXISTS notes_ad AFTER DELETE ON notes BEGIN
    INSERT INTO notes_fts (notes_fts, rowid, text) VALUES ('delete', old.rowid, old.text);
END;
CREATE TABLE IF NOT EXISTS visits (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, place TEXT NOT NULL,
    arrived REAL NOT NULL, departed REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS visits_by_time ON visits (robot_id, departed);
CREATE INDEX IF NOT EXISTS visits_by_arrival ON visits (robot_id, arrived);
CREATE TABLE IF NOT EXISTS forget_audit (
    id INTEGER PRIMARY KEY, robot_id TEXT NOT NULL, t REAL NOT NULL, request TEXT NOT NULL,
    result TEXT NOT NULL
);
"""

POSTGRES_BEFORE = """
CREATE TABLE IF NOT EXISTS episodic_sightings (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, skill TEXT NOT NULL,
    label TEXT NOT NULL, first_seen DOUBLE PRECISION NOT NULL,
    last_seen DOUBLE PRECISION NOT NULL, count INTEGER NOT NULL,
    best_score DOUBLE PRECISION NOT NULL, box TEXT, x DOUBLE PRECISION, y DOUBLE PRECISION,
    yaw DOUBLE PRECISION, place TEXT, absent_since DOUBLE PRECISION
);
CREATE INDEX IF NOT EXISTS episodic_sightings_by_time
    ON episodic_sightings (robot_id, last_seen);
CREATE INDEX IF NOT EXISTS episodic_sightings_by_label
    ON episodic_sightings (robot_id, label, last_seen);
CREATE INDEX IF NOT EXISTS episodic_sightings_by_start
    ON episodic_sightings (robot_id, first_seen);
CREATE TABLE IF NOT EXISTS episodic_poses (
    id BIGSERIAL PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL,
    t DOUBLE PRECISION NOT NULL, x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL,
    yaw DOUBLE PRECISION NOT NULL, place TEXT
);
CREATE INDEX IF NOT EXISTS episodic_poses_by_time ON episodic_poses (robot_id, t);
CREATE TABLE IF NOT EXISTS episodic_notes (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL,
    t DOUBLE PRECISION NOT NULL, kind TEXT NOT NULL, text TEXT NOT NULL, mission_id TEXT,
    place TEXT,
    document tsvector GENERATED ALWAYS AS (to_tsvector('english', text)) STORED
);
CREATE INDEX IF NOT EXISTS episodic_notes_by_time ON episodic_notes (robot_id, t);
CREATE INDEX IF NOT EXISTS episodic_notes_document ON episodic_notes USING GIN (document);
CREATE TABLE IF NOT EXISTS episodic_visits (
    id TEXT PRIMARY KEY, robot_id TEXT NOT NULL, map TEXT NOT NULL, place TEXT NOT NULL,
    arrived DOUBLE PRECISION NOT NULL, departed DOUBLE PRECISION NOT NULL
);
CREATE INDEX IF NOT EXISTS episodic_visits_by_time ON episodic_visits (robot_id, departed);
CREATE INDEX IF NOT EXISTS episodic_visits_by_arrival ON episodic_visits (robot_id, arrived);
CREATE TABLE IF NOT EXISTS episodic_forget_audit (
    id BIGSERIAL PRIMARY KEY, robot_id TEXT NOT NULL, t DOUBLE PRECISION NOT NULL,
    request TEXT NOT NULL, result TEXT NOT NULL
);
"""


def _sqlite_shape(path: Path) -> dict[str, Any]:
    """Every table's columns (name, type, pk; NOT NULL of non-key columns) and indexes."""
    with sqlite3.connect(path) as db:
        tables = [
            row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
        ]
        shape: dict[str, Any] = {}
        for table in tables:
            columns = db.execute(f"PRAGMA table_info('{table}')").fetchall()
            # A primary key is NOT NULL now; SQLite's legacy rule let a TEXT key be NULL.
            shape[table] = [(c[1], c[2], bool(c[3]) and not c[5], c[5]) for c in columns]
            for index in db.execute(f"PRAGMA index_list('{table}')").fetchall():
                if not index[1].startswith("sqlite_autoindex"):
                    info = db.execute(f"PRAGMA index_info('{index[1]}')").fetchall()
                    shape[index[1]] = [row[2] for row in info]
    return shape


def _postgres_shape(dsn: str) -> dict[str, Any]:
    with psycopg.connect(dsn) as conn:
        columns = conn.execute(
            "SELECT table_name, column_name, data_type, is_nullable, column_default, "
            "generation_expression FROM information_schema.columns "
            "WHERE table_schema = 'public' ORDER BY table_name, ordinal_position"
        ).fetchall()
        indexes = conn.execute(
            "SELECT indexname, indexdef FROM pg_indexes WHERE schemaname = 'public' "
            "ORDER BY indexname"
        ).fetchall()
    return {"columns": columns, "indexes": indexes}


def _fill_and_read(store: EpisodicStore) -> None:
    store.save_sightings([Sighting("s-1", "robot-1", "office", "detect", "mug", T, T + 5)])
    store.save_poses([PoseSample("robot-1", "office", T, 1.0, 2.0, 0.0, "kitchen")])
    store.save_notes([Note("n-1", "robot-1", "office", T, "scene", "a red mug on the table")])
    store.save_visits([Visit("v-1", "robot-1", "office", "kitchen", T, T + 60)])
    assert [s.id for s in store.sightings(T - 1, T + 10)] == ["s-0", "s-1"]
    assert sorted(hit.note.id for hit in store.search_notes(["mug"], T - 1, T + 1)) == [
        "n-0",
        "n-1",
    ]
    assert store.pose_near(T)[0] is not None
    assert [v.id for v in store.visits(T - 1, T + 100)] == ["v-1"]


OLD_SIGHTING = (
    "INSERT INTO {table} (id, robot_id, map, skill, label, first_seen, last_seen, count, "
    "best_score) VALUES ('s-0', 'robot-1', 'office', 'detect', 'mug', {t}, {t}, 1, 0.5)"
)
OLD_NOTE = (
    "INSERT INTO {table} (id, robot_id, map, t, kind, text) "
    "VALUES ('n-0', 'robot-1', 'office', {t}, 'scene', 'a mug')"
)


def test_an_sqlite_index_written_before_opens_unchanged(tmp_path: Path) -> None:
    path = tmp_path / "episodic.sqlite3"
    with sqlite3.connect(path) as db:
        db.executescript(SQLITE_BEFORE)
        db.execute(OLD_SIGHTING.format(table="sightings", t=T - 1))
        db.execute(OLD_NOTE.format(table="notes", t=T - 1))
    before = _sqlite_shape(path)

    store = SqliteEpisodicStore(path, "robot-1")
    try:
        _fill_and_read(store)
    finally:
        store.close()
    assert _sqlite_shape(path) == before


def test_a_new_sqlite_index_has_the_tables_the_hand_written_schema_made(tmp_path: Path) -> None:
    with sqlite3.connect(tmp_path / "before.sqlite3") as db:
        db.executescript(SQLITE_BEFORE)
    SqliteEpisodicStore(tmp_path / "now.sqlite3", "robot-1").close()

    now = _sqlite_shape(tmp_path / "now.sqlite3")
    assert now == _sqlite_shape(tmp_path / "before.sqlite3")
    assert ("id", "INTEGER", False, 1) in now["poses"]  # still the rowid


def test_a_postgres_index_written_before_opens_unchanged(postgres_dsn: str) -> None:
    with psycopg.connect(postgres_dsn) as conn:
        conn.execute(POSTGRES_BEFORE)
        conn.execute(OLD_SIGHTING.format(table="episodic_sightings", t=T - 1))
        conn.execute(OLD_NOTE.format(table="episodic_notes", t=T - 1))
    before = _postgres_shape(postgres_dsn)

    store = PostgresEpisodicStore(postgres_dsn, "robot-1")
    try:
        _fill_and_read(store)
    finally:
        store.close()
    assert _postgres_shape(postgres_dsn) == before


def test_a_new_postgres_index_has_the_tables_the_hand_written_schema_made(
    postgres_server: Any,
) -> None:
    before, now = postgres_server.create_database(), postgres_server.create_database()
    with psycopg.connect(before) as conn:
        conn.execute(POSTGRES_BEFORE)
    PostgresEpisodicStore(now, "robot-1").close()

    assert _postgres_shape(now) == _postgres_shape(before)
