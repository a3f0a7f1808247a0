"""PostgreSQL adapter of the episodic store: a fleet's robots share one database, every row
carries its ``robot_id`` and each server reads its own robot's rows. Notes are searched with a
stored English ``tsvector`` (GIN index) ranked by ``ts_rank``; any query term matches. The
statements are those of :mod:`.statements` compiled for PostgreSQL; this module holds what only
PostgreSQL has."""

from __future__ import annotations

import functools
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import psycopg
import sqlalchemy as sa
from psycopg.rows import TupleRow
from psycopg_pool import ConnectionPool
from sqlalchemy.dialects import postgresql
from sqlalchemy.dialects.postgresql.base import PGDialect

from robot_mcp_episodic.store.base import KINDS, StoreError
from robot_mcp_episodic.store.schema import episodic_tables
from robot_mcp_episodic.store.sql import Session, SqlEpisodicStore
from robot_mcp_episodic.store.statements import EpisodicStatements, Statement, numbered, param

Connection = psycopg.Connection[TupleRow]
SCHEMA_LOCK = 0x45504953  # pg_advisory_xact_lock key: one migration at a time

_DOCUMENT = sa.Column(
    "document",
    postgresql.TSVECTOR,
    sa.Computed("to_tsvector('english', text)", persisted=True),
)
TABLES = episodic_tables("episodic_", _DOCUMENT)
FULL_TEXT_INDEX = sa.Index(
    "episodic_notes_document", TABLES.notes.c.document, postgresql_using="gin"
)
# The base dialect: psycopg's own would add a cast to every bound parameter.
DIALECT = PGDialect(paramstyle="pyformat")  # type: ignore[no-untyped-call]
STATEMENTS = EpisodicStatements(TABLES, DIALECT, postgresql.insert)


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def _search(terms: int, at_place: bool) -> sa.ClauseElement:
    """Notes matching any of ``terms`` (``term_<i>``), best first, ties the newest first."""
    notes = TABLES.notes
    english: sa.ColumnElement[str] = sa.literal_column("'english'")
    queries: list[sa.ColumnElement[Any]] = [
        sa.func.plainto_tsquery(english, param(f"term_{i}")) for i in range(terms)
    ]
    query = sa.select(functools.reduce(lambda a, b: a.op("||")(b), queries).label("query"))
    q = query.subquery("q")
    score = sa.func.ts_rank(notes.c.document, q.c.query).label("score")
    return (
        STATEMENTS.notes_in_window(at_place)
        .add_columns(score)
        .select_from(q)
        .where(notes.c.document.op("@@")(q.c.query))
        .order_by(score.desc(), notes.c.t.desc())
        .limit(param("limit"))
    )


class PostgresEpisodicStore(SqlEpisodicStore):
    def __init__(
        self, dsn: str, robot_id: str, *, pool_size: int = 4, connect_timeout_s: float = 5.0
    ) -> None:
        self.robot_id = robot_id
        self.sql = STATEMENTS
        timeout = max(1, round(connect_timeout_s))
        try:
            with psycopg.connect(dsn, connect_timeout=timeout) as conn, conn.transaction():
                conn.execute("SELECT pg_advisory_xact_lock(%s)", (SCHEMA_LOCK,))
                for statement in TABLES.ddl(DIALECT):
                    conn.execute(statement)
                full_text = sa.schema.CreateIndex(FULL_TEXT_INDEX, if_not_exists=True)
                conn.execute(str(full_text.compile(dialect=DIALECT)))
        except psycopg.ProgrammingError as exc:
            raise StoreError("EPISODIC_POSTGRES_DSN is not a valid connection string") from exc
        except psycopg.Error as exc:
            raise StoreError(f"cannot open the episodic index: {_first_line(exc)}") from exc
        self._pool: ConnectionPool[Connection] = ConnectionPool(
            dsn,
            min_size=1,
            max_size=pool_size,
            kwargs={"connect_timeout": timeout},
            timeout=connect_timeout_s,
            open=False,
            name=f"episodic-{robot_id}",
        )
        try:
            self._pool.open(wait=True, timeout=connect_timeout_s)
        except psycopg.Error as exc:
            self._pool.close()
            raise StoreError(f"cannot open the episodic index: {_first_line(exc)}") from exc

    @contextmanager
    def _session(self, *, write: bool) -> Iterator[Session]:
        try:
            with self._pool.connection() as conn, conn.transaction():
                yield Session(conn)
        except psycopg.Error as exc:
            raise StoreError(f"episodic index failed: {_first_line(exc)}") from exc

    def _size_bytes(self, session: Session) -> int:
        [row] = session.rows(self._size_statement())
        return int(row[0])

    def _size_statement(self) -> Statement:
        def build() -> sa.ClauseElement:
            sizes: list[sa.ColumnElement[Any]] = [
                sa.func.pg_total_relation_size(sa.literal_column(f"'{TABLES.of(kind).name}'"))
                for kind in KINDS
            ]
            return sa.select(functools.reduce(lambda a, b: a + b, sizes))

        return self.sql.compiled("size", build)

    def _search(self, terms: Sequence[str], at_place: bool) -> tuple[Statement, dict[str, Any]]:
        statement = self.sql.compiled(
            ("search", len(terms), at_place), lambda: _search(len(terms), at_place)
        )
        return statement, numbered("term", terms)

    def _score(self, raw: Any) -> float:
        return round(float(raw), 4)

    def close(self) -> None:
        self._pool.close()
