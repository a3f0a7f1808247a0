"""SQLite adapter of the episodic store: one file in WAL mode (readers never wait for the
ingest writer), FTS5 over notes, indexes on (robot_id, time). The statements are those of
:mod:`.statements` compiled for SQLite; this module holds what only SQLite has."""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.dialects import sqlite
from sqlalchemy.dialects.sqlite.base import SQLiteCompiler
from sqlalchemy.sql.expression import FromClause

from robot_mcp_episodic.store.base import StoreError
from robot_mcp_episodic.store.schema import episodic_tables
from robot_mcp_episodic.store.sql import Session, SqlEpisodicStore
from robot_mcp_episodic.store.statements import EpisodicStatements, Statement, param

TABLES = episodic_tables()

# Full text over notes: an external-content FTS5 table kept by triggers.
FTS_SCHEMA = """
CREATE VIRTUAL TABLE IF NOT EXISTS notes_fts USING fts5 (
    text, content='notes', content_rowid='rowid', tokenize='porter unicode61'
);
CREATE TRIGGER IF NOT EXISTS notes_ai AFTER INSERT ON notes BEGIN
    INSERT INTO notes_fts (rowid, text) VALUES (new.rowid, new.text);
END;
CREATE TRIGGER IF NOT EXISTS notes_ad AFTER DELETE ON notes BEGIN
    INSERT INTO notes_fts (notes_fts, rowid, text) VALUES ('delete', old.rowid, old.text);
END;
"""


class _Compiler(SQLiteCompiler):
    def get_from_hint_text(self, table: FromClause, text: str | None) -> str | None:
        """Render ``with_hint(table, "INDEXED BY ...", "sqlite")`` after the table's name."""
        return text


class _Dialect(sqlite.dialect):  # type: ignore[misc,valid-type]
    statement_compiler = _Compiler


DIALECT = _Dialect(paramstyle="named")
STATEMENTS = EpisodicStatements(TABLES, DIALECT, sqlite.insert)


def fts_query(terms: Sequence[str]) -> str:
    """Any of ``terms``, each quoted (FTS5 syntax characters in a term are literal)."""
    return " OR ".join('"' + term.replace('"', '""') + '"' for term in terms)


class SqliteEpisodicStore(SqlEpisodicStore):
    def __init__(self, path: Path, robot_id: str) -> None:
        self.robot_id = robot_id
        self.path = path
        self.sql = STATEMENTS
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(path, check_same_thread=False, isolation_level=None)
            # Before the first table exists: lets compact() give deleted pages back.
            self._db.execute("PRAGMA auto_vacuum=INCREMENTAL")
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute("PRAGMA busy_timeout=5000")
            self._db.executescript(";\n".join(TABLES.ddl(DIALECT)) + ";\n" + FTS_SCHEMA)
        except (sqlite3.Error, OSError) as exc:
            raise StoreError(f"cannot open the episodic index {path}: {exc}") from exc
        self._lock = threading.Lock()

    @contextmanager
    def _session(self, *, write: bool) -> Iterator[Session]:
        with self._lock:
            try:
                if not write:
                    yield Session(self._db)
                    return
                self._db.execute("BEGIN IMMEDIATE")
                try:
                    yield Session(self._db)
                except BaseException:
                    self._db.execute("ROLLBACK")
                    raise
                self._db.execute("COMMIT")
            except sqlite3.Error as exc:
                what = "write" if write else "read"
                raise StoreError(f"episodic index {what} failed: {exc}") from exc

    def _read(self, statement: Statement, params: Mapping[str, Any]) -> list[Sequence[Any]]:
        # The hot path of every question: no transaction to open, one lock.
        with self._lock:
            try:
                return self._db.execute(statement.sql, statement.params(params)).fetchall()
            except sqlite3.Error as exc:
                raise StoreError(f"episodic index read failed: {exc}") from exc

    def _size_bytes(self, session: Session) -> int:
        return sum(
            candidate.stat().st_size
            for candidate in (self.path, Path(f"{self.path}-wal"))
            if candidate.exists()
        )

    def _search(self, terms: Sequence[str], at_place: bool) -> tuple[Statement, dict[str, Any]]:
        def build() -> sa.ClauseElement:
            notes, fts = TABLES.notes, sa.table("notes_fts")
            rank = sa.func.bm25(sa.literal_column("notes_fts"))
            on_row = sa.literal_column("notes.rowid") == sa.literal_column("notes_fts.rowid")
            joined = fts.join(notes, on_row)
            return (
                self.sql.notes_in_window(at_place)
                .add_columns(rank)
                .select_from(joined)
                .where(sa.literal_column("notes_fts").op("MATCH")(param("match")))
                .order_by(rank)
                .limit(param("limit"))
            )

        return self.sql.compiled(("search", at_place), build), {"match": fts_query(terms)}

    def _score(self, raw: Any) -> float:
        # bm25() is lower-is-better; a term in most notes has an IDF near zero.
        return round(max(0.0, -float(raw)), 6)

    def compact(self) -> None:
        with self._lock:
            try:
                # execute() steps the pragma once (one page); executescript runs it to the end.
                self._db.executescript("PRAGMA incremental_vacuum;")
                self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
            except sqlite3.Error as exc:
                raise StoreError(f"episodic index compaction failed: {exc}") from exc

    def close(self) -> None:
        with self._lock:
            self._db.close()
