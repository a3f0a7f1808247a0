"""SqliteFtsProcessStore: the embedded ProcessStore — one SQLite file, FTS5 BM25 search.

Tables: ``process_versions`` (every version ever saved, with the robot that saved it),
``processes`` (one row per scope and id: the current version pointer), ``outcomes`` (the outcome
log: robot, success, note; counts are aggregated from it) and ``process_fts`` (FTS5, ``porter
unicode61`` tokenizer, one row per process holding its current version; rowid =
``processes.rowid``). Several robots may share a file: each FTS row carries a token of its scope
(:func:`~robot_mcp_memory.store.base.scope_of`) and every search is constrained to it. The schema
is versioned (``PRAGMA user_version``, :data:`MIGRATIONS`), migrated at open inside one
``BEGIN IMMEDIATE`` transaction, so servers opening one file together migrate it once.

Writes run in ``BEGIN IMMEDIATE`` transactions: SQLite's single writer lock makes concurrent
saves (threads or processes) serializable, so a version history never has gaps or duplicates.

Ranking is FTS5's ``bm25()`` (column weights :data:`BM25_WEIGHTS`). Its idf,
``log((N − n + 0.5) / (n + 0.5))``, is ≤ 0 (clamped to 1e-6) for a word found in half the rows
or more, which makes a robot's first few processes indistinguishable (with N = 2, a word found
in one of them weighs nothing). :data:`SMOOTHING_ROWS` rows of filler of a typical document's
length (negative rowids, a scope no robot has, so they never match) raise N by a constant and
keep the average lengths realistic: small stores rank sensibly, and at 10,000 processes the
effect is nil. A query runs as two passes, the caller's words over the text columns and their
synonym concepts over the ``concepts`` column (weighted lower, see
:class:`~robot_mcp_memory.store.base.SearchQuery`), each taking its best ``limit`` rows; a row's
relevance is the weighted sum of its passes. The ``meta`` table records the synonym list's
version; when it changes, the indexed concepts are re-derived at open.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

from robot_mcp_memory.documents import ProcessDocument
from robot_mcp_memory.query import SYNONYMS_VERSION, document_concepts
from robot_mcp_memory.store.base import (
    Candidate,
    OutcomeRecord,
    OutcomeStats,
    ProcessNotFoundError,
    ProcessStore,
    ProcessSummary,
    SaveResult,
    SearchQuery,
    StoredProcess,
    StoreError,
    Visibility,
    scope_of,
)

SMOOTHING_ROWS = 8
_FILLER = "zzsmoothing"
# Tokens in title, task_pattern, tags, body, concepts: a typical document.
_FILLER_LENGTHS = (6, 12, 3, 100, 10)

# BM25 column weights: scope (never matched by content), title, task_pattern, tags, body,
# concepts (matched only by the concept pass, whose total is weighted separately).
BM25_WEIGHTS = (0.0, 4.0, 3.0, 2.0, 1.0, 1.0)

_SCHEMA_V1 = (
    """CREATE TABLE IF NOT EXISTS processes (
        rowid INTEGER PRIMARY KEY,
        robot_id TEXT NOT NULL,
        process_id TEXT NOT NULL,
        current_version INTEGER NOT NULL,
        created_at REAL NOT NULL,
        updated_at REAL NOT NULL,
        UNIQUE (robot_id, process_id)
    )""",
    """CREATE TABLE IF NOT EXISTS process_versions (
        robot_id TEXT NOT NULL,
        process_id TEXT NOT NULL,
        version INTEGER NOT NULL,
        title TEXT NOT NULL,
        task_pattern TEXT NOT NULL,
        tags_json TEXT NOT NULL,
        markdown TEXT NOT NULL,
        created_at REAL NOT NULL,
        successes INTEGER NOT NULL DEFAULT 0,
        failures INTEGER NOT NULL DEFAULT 0,
        PRIMARY KEY (robot_id, process_id, version)
    )""",
    """CREATE TABLE IF NOT EXISTS outcomes (
        id INTEGER PRIMARY KEY,
        robot_id TEXT NOT NULL,
        process_id TEXT NOT NULL,
        version INTEGER NOT NULL,
        success INTEGER NOT NULL,
        note TEXT NOT NULL,
        recorded_at REAL NOT NULL
    )""",
    "CREATE INDEX IF NOT EXISTS outcomes_by_process "
    "ON outcomes (robot_id, process_id, version, id)",
    "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    """CREATE VIRTUAL TABLE IF NOT EXISTS process_fts USING fts5(
        scope, title, task_pattern, tags, body, concepts,
        tokenize = 'porter unicode61 remove_diacritics 2'
    )""",
)

# Version 2: fleet scope. Processes live in a scope ("robot:<id>" or "fleet"), each version keeps
# the robot that saved it, each outcome its robot; counts come from the outcome log.
_SCHEMA_V2 = (
    "ALTER TABLE processes RENAME COLUMN robot_id TO scope",
    "ALTER TABLE process_versions RENAME COLUMN robot_id TO scope",
    "ALTER TABLE process_versions ADD COLUMN saved_by TEXT NOT NULL DEFAULT ''",
    "UPDATE process_versions SET saved_by = scope, scope = 'robot:' || scope",
    "UPDATE processes SET scope = 'robot:' || scope",
    "ALTER TABLE outcomes ADD COLUMN scope TEXT NOT NULL DEFAULT ''",
    "UPDATE outcomes SET scope = 'robot:' || robot_id",
    "DROP INDEX outcomes_by_process",
    "CREATE INDEX outcomes_by_version ON outcomes (scope, process_id, version, id)",
)


def _rescope_fts(conn: sqlite3.Connection) -> None:
    rows = conn.execute("SELECT rowid, scope FROM processes").fetchall()
    for rowid, scope in rows:
        conn.execute(
            "UPDATE process_fts SET scope = ? WHERE rowid = ?", (scope_token(scope), rowid)
        )


def _statements(*sql: str) -> Callable[[sqlite3.Connection], None]:
    def apply(conn: sqlite3.Connection) -> None:
        for statement in sql:
            conn.execute(statement)

    return apply


def _v2(conn: sqlite3.Connection) -> None:
    _statements(*_SCHEMA_V2)(conn)
    _rescope_fts(conn)


# Schema version → migration from the version before it (applied in order at open).
MIGRATIONS: dict[int, Callable[[sqlite3.Connection], None]] = {
    1: _statements(*_SCHEMA_V1),
    2: _v2,
}
SCHEMA_VERSION = max(MIGRATIONS)


def _count(success: int, robot_only: bool) -> str:
    robot = " AND o.robot_id = :robot" if robot_only else ""
    return (
        "(SELECT count(*) FROM outcomes o WHERE o.scope = v.scope AND o.process_id = "  # noqa: S608 - constant SQL
        f"v.process_id AND o.version = v.version AND o.success = {success}{robot})"
    )


# Columns of a version row (:func:`_stored`), outcome counts aggregated from the log.
_VERSION_COLUMNS = (
    "v.process_id, v.version, p.current_version, v.title, v.task_pattern, v.tags_json, "
    "v.markdown, v.created_at, v.saved_by, "
    + ", ".join(_count(success, robot) for robot in (False, True) for success in (1, 0))
)
_CURRENT = (
    "FROM processes p JOIN process_versions v ON v.scope = p.scope "
    "AND v.process_id = p.process_id AND v.version = p.current_version"
)

T = TypeVar("T")


def scope_token(scope: str) -> str:
    """One FTS token naming a scope: 'r' + hex of its UTF-8 name (no tokenizer can split it)."""
    return "r" + scope.encode().hex()


def render_match(terms: tuple[str, ...]) -> str:
    """FTS5 MATCH text for ``terms``: an OR of quoted words/phrases. Terms hold only word
    characters and spaces (see :mod:`robot_mcp_memory.query`); quotes are doubled anyway."""
    quoted = ('"' + " ".join(term.split()).replace('"', '""') + '"' for term in terms)
    return " OR ".join(dict.fromkeys(q for q in quoted if q != '""'))


class SqliteFtsProcessStore(ProcessStore):
    """Process store in one SQLite file (WAL mode); thread-safe through one locked connection."""

    def __init__(
        self,
        path: str | Path,
        robot_id: str,
        *,
        visibility: Visibility = "robot",
        busy_timeout_s: float = 5.0,
    ) -> None:
        self.scope = scope_of(robot_id, visibility)
        self.robot_id = robot_id
        self.visibility = visibility
        self.path = Path(path)
        self._token = scope_token(self.scope)
        self._lock = threading.Lock()
        if str(path) != ":memory:":
            self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self._conn = sqlite3.connect(
                str(path), timeout=busy_timeout_s, isolation_level=None, check_same_thread=False
            )
            self._conn.execute("PRAGMA journal_mode = WAL")
            self._conn.execute("PRAGMA synchronous = NORMAL")
            self._conn.execute("PRAGMA foreign_keys = ON")
            self._migrate()
            self._add_smoothing_rows()
            self._refresh_concepts()
        except sqlite3.Error as exc:
            if "fts5" in str(exc).lower():
                raise StoreError(
                    "this Python's SQLite was built without FTS5, which the memory store needs"
                ) from exc
            raise StoreError(f"cannot open the process store at {path}: {exc}") from exc

    # -- plumbing -------------------------------------------------------------------------

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        with self._lock:
            self._conn.execute("BEGIN IMMEDIATE")
            try:
                yield self._conn
            except BaseException:
                self._conn.execute("ROLLBACK")
                raise
            self._conn.execute("COMMIT")

    def _read(self, work: Callable[[sqlite3.Connection], T]) -> T:
        with self._lock:
            try:
                return work(self._conn)
            except sqlite3.Error as exc:
                raise StoreError(f"process store read failed: {exc}") from exc

    def _migrate(self) -> None:
        """Apply the pending :data:`MIGRATIONS` under the write lock (once per file)."""
        with self._transaction() as conn:
            current = int(conn.execute("PRAGMA user_version").fetchone()[0])
            if current > SCHEMA_VERSION:
                raise StoreError(
                    f"the process store at {self.path} has schema version {current}, newer than "
                    f"this server's {SCHEMA_VERSION}; upgrade robot-mcp-memory"
                )
            for version in range(current + 1, SCHEMA_VERSION + 1):
                MIGRATIONS[version](conn)
                conn.execute(f"PRAGMA user_version = {version}")

    def _add_smoothing_rows(self) -> None:
        with self._transaction() as conn:
            present = conn.execute("SELECT count(*) FROM process_fts WHERE rowid < 0").fetchone()
            if int(present[0]) >= SMOOTHING_ROWS:
                return
            conn.execute("DELETE FROM process_fts WHERE rowid < 0")
            for rowid in range(-SMOOTHING_ROWS, 0):
                conn.execute(
                    "INSERT INTO process_fts (rowid, scope, title, task_pattern, tags, body, "
                    "concepts) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (rowid, "smoothing", *(" ".join([_FILLER] * n) for n in _FILLER_LENGTHS)),
                )

    def _refresh_concepts(self) -> None:
        """Re-derive indexed concepts of every current version when the synonym list changed."""
        with self._transaction() as conn:
            row = conn.execute("SELECT value FROM meta WHERE key = 'synonyms_version'").fetchone()
            if row is not None and row[0] == SYNONYMS_VERSION:
                return
            current = conn.execute(
                f"SELECT p.rowid, v.title, v.task_pattern, v.tags_json, f.body {_CURRENT} "
                "JOIN process_fts f ON f.rowid = p.rowid"
            ).fetchall()
            for rowid, title, task_pattern, tags_json, body in current:
                conn.execute(
                    "UPDATE process_fts SET concepts = ? WHERE rowid = ?",
                    (
                        document_concepts(title, task_pattern, tuple(json.loads(tags_json)), body),
                        rowid,
                    ),
                )
            conn.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES ('synonyms_version', ?)",
                (SYNONYMS_VERSION,),
            )

    def close(self) -> None:
        with self._lock:
            self._conn.close()

    # -- port -------------------------------------------------------------------------------

    def save(self, document: ProcessDocument) -> SaveResult:
        now = time.time()
        try:
            with self._transaction() as conn:
                row = conn.execute(
                    "SELECT rowid, current_version FROM processes "
                    "WHERE scope = ? AND process_id = ?",
                    (self.scope, document.id),
                ).fetchone()
                if row is not None:
                    current = self._get(conn, document.id, None)
                    if current.markdown == document.markdown:
                        return SaveResult(process=current, created=False)
                version = 1 if row is None else int(row[1]) + 1
                conn.execute(
                    "INSERT INTO process_versions (scope, process_id, version, saved_by, title, "
                    "task_pattern, tags_json, markdown, created_at) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        self.scope,
                        document.id,
                        version,
                        self.robot_id,
                        document.title,
                        document.task_pattern,
                        json.dumps(list(document.tags)),
                        document.markdown,
                        now,
                    ),
                )
                if row is None:
                    cursor = conn.execute(
                        "INSERT INTO processes (scope, process_id, current_version, "
                        "created_at, updated_at) VALUES (?, ?, ?, ?, ?)",
                        (self.scope, document.id, version, now, now),
                    )
                    rowid = cursor.lastrowid
                else:
                    rowid = int(row[0])
                    conn.execute(
                        "UPDATE processes SET current_version = ?, updated_at = ? WHERE rowid = ?",
                        (version, now, rowid),
                    )
                    conn.execute("DELETE FROM process_fts WHERE rowid = ?", (rowid,))
                conn.execute(
                    "INSERT INTO process_fts (rowid, scope, title, task_pattern, tags, body, "
                    "concepts) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (
                        rowid,
                        self._token,
                        document.title,
                        document.task_pattern,
                        " ".join(document.tags),
                        document.body,
                        document_concepts(
                            document.title, document.task_pattern, document.tags, document.body
                        ),
                    ),
                )
                return SaveResult(process=self._get(conn, document.id, None), created=True)
        except sqlite3.Error as exc:
            raise StoreError(f"saving process '{document.id}' failed: {exc}") from exc

    def get(self, process_id: str, version: int | None = None) -> StoredProcess:
        return self._read(lambda conn: self._get(conn, process_id, version))

    def list_processes(self) -> list[ProcessSummary]:
        def work(conn: sqlite3.Connection) -> list[ProcessSummary]:
            rows = conn.execute(
                f"SELECT {_VERSION_COLUMNS}, p.updated_at {_CURRENT} "
                "WHERE p.scope = :scope ORDER BY p.updated_at DESC, p.process_id",
                {"scope": self.scope, "robot": self.robot_id},
            ).fetchall()
            return [ProcessSummary.of(_stored(row[:-1]), float(row[-1])) for row in rows]

        return self._read(work)

    def search(self, query: SearchQuery, limit: int) -> list[Candidate]:
        if query.empty or limit <= 0:
            return []
        weights = ", ".join(str(weight) for weight in BM25_WEIGHTS)
        sql = (
            f"SELECT rowid, -bm25(process_fts, {weights}) AS score FROM process_fts "  # noqa: S608 - constant weights
            "WHERE process_fts MATCH ? ORDER BY score DESC LIMIT ?"
        )
        passes = (
            ("{title task_pattern tags body}", query.words, 1.0),
            ("concepts", query.concepts, query.concept_weight),
        )

        def work(conn: sqlite3.Connection) -> list[Candidate]:
            scores: dict[int, float] = {}
            for columns, terms, weight in passes:
                match = render_match(terms)
                if not match or weight <= 0:
                    continue
                expression = f'scope : "{self._token}" AND {columns} : ({match})'
                for rowid, score in conn.execute(sql, (expression, limit)):
                    scores[rowid] = scores.get(rowid, 0.0) + weight * max(float(score), 0.0)
            best = sorted(scores.items(), key=lambda item: (-item[1], item[0]))[:limit]
            if not best:
                return []
            marks = ", ".join(f":r{index}" for index in range(len(best)))
            rows = conn.execute(
                f"SELECT p.rowid, {_VERSION_COLUMNS} {_CURRENT} "
                # "+" keeps the planner on the rowid lookup instead of scanning the scope's rows
                f"WHERE +p.scope = :scope AND p.rowid IN ({marks})",
                {
                    "scope": self.scope,
                    "robot": self.robot_id,
                    **{f"r{index}": rowid for index, (rowid, _) in enumerate(best)},
                },
            ).fetchall()
            by_rowid = {row[0]: _stored(row[1:]) for row in rows}
            return [
                Candidate(process=by_rowid[rowid], relevance=score)
                for rowid, score in best
                if rowid in by_rowid
            ]

        return self._read(work)

    def record_outcome(self, process_id: str, success: bool, note: str) -> StoredProcess:
        try:
            with self._transaction() as conn:
                current = self._get(conn, process_id, None)
                conn.execute(
                    "INSERT INTO outcomes (scope, robot_id, process_id, version, success, note, "
                    "recorded_at) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (
                        self.scope,
                        self.robot_id,
                        process_id,
                        current.version,
                        int(success),
                        note,
                        time.time(),
                    ),
                )
                return self._get(conn, process_id, None)
        except sqlite3.Error as exc:
            raise StoreError(f"recording an outcome for '{process_id}' failed: {exc}") from exc

    def recent_outcomes(
        self, process_id: str, version: int | None = None, limit: int = 5
    ) -> list[OutcomeRecord]:
        def work(conn: sqlite3.Connection) -> list[OutcomeRecord]:
            target = self._get(conn, process_id, version).version
            rows = conn.execute(
                "SELECT version, success, note, recorded_at, robot_id FROM outcomes "
                "WHERE scope = ? AND process_id = ? AND version = ? ORDER BY id DESC LIMIT ?",
                (self.scope, process_id, target, limit),
            ).fetchall()
            return [
                OutcomeRecord(
                    version=int(row[0]),
                    success=bool(row[1]),
                    note=row[2],
                    recorded_at=row[3],
                    robot_id=row[4],
                )
                for row in rows
            ]

        return self._read(work)

    # -- helpers ----------------------------------------------------------------------------

    def _get(self, conn: sqlite3.Connection, process_id: str, version: int | None) -> StoredProcess:
        sql = (
            f"SELECT {_VERSION_COLUMNS} FROM processes p "  # noqa: S608 - constant columns
            "JOIN process_versions v ON v.scope = p.scope AND v.process_id = p.process_id "
            "WHERE p.scope = :scope AND p.process_id = :id AND v.version = "
            + ("p.current_version" if version is None else ":version")
        )
        params = {"scope": self.scope, "robot": self.robot_id, "id": process_id}
        row = conn.execute(sql, {**params, "version": version}).fetchone()
        if row is None:
            raise ProcessNotFoundError(process_id, version)
        return _stored(row)


def _stored(row: Sequence[Any]) -> StoredProcess:
    return StoredProcess(
        id=str(row[0]),
        version=int(row[1]),
        current_version=int(row[2]),
        title=str(row[3]),
        task_pattern=str(row[4]),
        tags=tuple(json.loads(str(row[5]))),
        markdown=str(row[6]),
        created_at=float(row[7]),
        saved_by=str(row[8]),
        stats=OutcomeStats(successes=int(row[9]), failures=int(row[10])),
        robot_stats=OutcomeStats(successes=int(row[11]), failures=int(row[12])),
    )
