"""Versioned schema of the PostgreSQL process store, migrated at start-up.

Every server opening the database runs :func:`migrate`: under a transaction-scoped advisory lock
(:data:`MIGRATION_LOCK`) it reads the applied versions from ``memory_schema`` and applies the
missing :data:`MIGRATIONS` in order, in the same transaction (PostgreSQL DDL is transactional).
Servers starting together queue on the lock; the first migrates, the others find nothing to do.
The synonym concepts indexed per process are re-derived under the same lock when the synonym
list (:data:`robot_mcp_memory.query.SYNONYMS_VERSION`) changed.
"""

from __future__ import annotations

import psycopg
from psycopg.rows import TupleRow

from robot_mcp_memory.query import SYNONYMS_VERSION, document_concepts
from robot_mcp_memory.store.base import StoreError

# pg_advisory_xact_lock key shared by every memory server (any constant unlikely to collide).
MIGRATION_LOCK = 0x6D656D6F7279  # "memory"

# Documents are weighted A title, B task pattern, C tags, D body (ts_rank_cd's {D, C, B, A}).
DOCUMENT_VECTOR = (
    "setweight(to_tsvector('english', %(title)s), 'A') || "
    "setweight(to_tsvector('english', %(task_pattern)s), 'B') || "
    "setweight(to_tsvector('english', %(tags)s), 'C') || "
    "setweight(to_tsvector('english', %(body)s), 'D')"
)
CONCEPT_VECTOR = "to_tsvector('simple', %(concepts)s)"

_V1 = (
    """CREATE TABLE processes (
        scope text NOT NULL,
        process_id text NOT NULL,
        current_version integer NOT NULL,
        created_at double precision NOT NULL,
        updated_at double precision NOT NULL,
        document tsvector NOT NULL DEFAULT ''::tsvector,
        concepts tsvector NOT NULL DEFAULT ''::tsvector,
        PRIMARY KEY (scope, process_id)
    )""",
    "CREATE INDEX processes_document ON processes USING gin (document)",
    "CREATE INDEX processes_concepts ON processes USING gin (concepts)",
    "CREATE INDEX processes_recent ON processes (scope, updated_at DESC)",
    """CREATE TABLE process_versions (
        scope text NOT NULL,
        process_id text NOT NULL,
        version integer NOT NULL CHECK (version >= 1),
        saved_by text NOT NULL,
        title text NOT NULL,
        task_pattern text NOT NULL,
        tags text[] NOT NULL,
        body text NOT NULL,
        markdown text NOT NULL,
        created_at double precision NOT NULL,
        PRIMARY KEY (scope, process_id, version),
        FOREIGN KEY (scope, process_id) REFERENCES processes (scope, process_id)
    )""",
    """CREATE TABLE outcomes (
        id bigserial PRIMARY KEY,
        scope text NOT NULL,
        process_id text NOT NULL,
        version integer NOT NULL,
        robot_id text NOT NULL,
        success boolean NOT NULL,
        note text NOT NULL,
        recorded_at double precision NOT NULL,
        FOREIGN KEY (scope, process_id, version)
            REFERENCES process_versions (scope, process_id, version)
    )""",
    "CREATE INDEX outcomes_by_version ON outcomes (scope, process_id, version, id)",
    "CREATE TABLE memory_meta (key text PRIMARY KEY, value text NOT NULL)",
)

# Version 2: BM25 ranking. ``document_length`` is the number of tokens indexed in ``document``
# (BM25's document length; the average over a scope is its avgdl), kept by PostgreSQL itself:
# a stored generated column, filled for existing rows when it is added.
_V2 = (
    """CREATE FUNCTION memory_token_count(tsvector) RETURNS integer
        LANGUAGE sql IMMUTABLE STRICT PARALLEL SAFE
        AS $$ SELECT coalesce(sum(cardinality(positions)), 0)::integer FROM unnest($1) $$""",
    "ALTER TABLE processes ADD COLUMN document_length integer NOT NULL "
    "GENERATED ALWAYS AS (memory_token_count(document)) STORED",
)

# Schema version → its statements; append new versions, never edit applied ones.
MIGRATIONS: dict[int, tuple[str, ...]] = {1: _V1, 2: _V2}
SCHEMA_VERSION = max(MIGRATIONS)


def migrate(conn: psycopg.Connection[TupleRow]) -> int:
    """Bring the database to :data:`SCHEMA_VERSION`; returns how many migrations ran."""
    with conn.transaction():
        conn.execute("SELECT pg_advisory_xact_lock(%s)", (MIGRATION_LOCK,))
        conn.execute(
            "CREATE TABLE IF NOT EXISTS memory_schema ("
            "version integer PRIMARY KEY, applied_at timestamptz NOT NULL DEFAULT now())"
        )
        row = conn.execute("SELECT coalesce(max(version), 0) FROM memory_schema").fetchone()
        current = int(row[0]) if row else 0
        if current > SCHEMA_VERSION:
            raise StoreError(
                f"the PostgreSQL process store has schema version {current}, newer than this "
                f"server's {SCHEMA_VERSION}; upgrade robot-mcp-memory"
            )
        for version in range(current + 1, SCHEMA_VERSION + 1):
            for statement in MIGRATIONS[version]:
                conn.execute(statement)
            conn.execute("INSERT INTO memory_schema (version) VALUES (%s)", (version,))
        _refresh_concepts(conn)
    return SCHEMA_VERSION - current


def _refresh_concepts(conn: psycopg.Connection[TupleRow]) -> None:
    row = conn.execute("SELECT value FROM memory_meta WHERE key = 'synonyms_version'").fetchone()
    if row is not None and row[0] == SYNONYMS_VERSION:
        return
    current = conn.execute(
        "SELECT p.scope, p.process_id, v.title, v.task_pattern, v.tags, v.body "
        "FROM processes p JOIN process_versions v ON v.scope = p.scope "
        "AND v.process_id = p.process_id AND v.version = p.current_version"
    ).fetchall()
    for scope, process_id, title, task_pattern, tags, body in current:
        conn.execute(
            f"UPDATE processes SET concepts = {CONCEPT_VECTOR} "  # noqa: S608 - constant SQL
            "WHERE scope = %(scope)s AND process_id = %(id)s",
            {
                "concepts": document_concepts(
                    str(title), str(task_pattern), tuple(tags), str(body)
                ),
                "scope": scope,
                "id": process_id,
            },
        )
    conn.execute(
        "INSERT INTO memory_meta (key, value) VALUES ('synonyms_version', %s) "
        "ON CONFLICT (key) DO UPDATE SET value = excluded.value",
        (SYNONYMS_VERSION,),
    )
