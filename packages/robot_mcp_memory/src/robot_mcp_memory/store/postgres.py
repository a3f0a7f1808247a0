"""PostgresProcessStore: the fleet's ProcessStore — one PostgreSQL database shared by robots.

Tables (:mod:`.postgres_schema`): ``processes`` (one row per scope and id: the current version
pointer plus its ``document`` tsvector — title A, task pattern B, tags C, body D, English
stemming —, its token count ``document_length`` and its ``concepts`` tsvector of synonym
concepts), ``process_versions`` (every version, with the robot that saved it) and ``outcomes``
(robot, success, note; counts are aggregated from it per version, fleet-wide and for this robot).

Search is BM25 computed in SQL (:data:`_SEARCH`), as FTS5's ``bm25()`` ranks on SQLite: every
query word (``phraseto_tsquery('english', ...)``) and concept (``'simple'``) is a term of its own,
weighted by its inverse document frequency within the scope, so the rare word that tells
processes apart outranks the common ones most processes share ("robot", "take", "room"); a
term's frequency is weighted by field (title 4 : task pattern 3 : tags 2 : body 1), saturates
(k1) and is normalized by document length (b). Terms are bound parameters read as plain text
(no operator in them means anything). The outcome adjustment of :mod:`robot_mcp_memory.ranking`
is applied above the port as for every adapter.

Concurrency: transactions run at READ COMMITTED. A save first makes sure the process's head row
exists (``INSERT … ON CONFLICT DO NOTHING``), then locks it (``SELECT … FOR UPDATE``) and
reads the current version under that lock: saves of one id from any number of servers are
serialized on that row (version numbers strictly increase by one, the identical-text check
sees the latest version), saves of different ids never wait for each other, and nothing has to
be retried as it would under SERIALIZABLE. An outcome takes a share lock on the head row, so
it counts against the version that is current when it commits.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import psycopg
from psycopg.rows import TupleRow
from psycopg_pool import ConnectionPool

from robot_mcp_memory.documents import ProcessDocument
from robot_mcp_memory.query import document_concepts
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
from robot_mcp_memory.store.postgres_schema import CONCEPT_VECTOR, DOCUMENT_VECTOR, migrate

T = TypeVar("T")
Connection = psycopg.Connection[TupleRow]

# BM25 parameters (as FTS5's bm25() on SQLite): term-frequency saturation and length normalization.
BM25_K1 = 1.2
BM25_B = 0.75
# Field weights in ts_rank_cd's order {D, C, B, A}, scaled by FIELD_SCALE: body 1, tags 2, task
# pattern 3, title 4 (ts_rank_cd takes weights ≤ 1; with normalization 0 and a one-term query it
# returns the sum of the weights of the term's occurrences).
FIELD_WEIGHTS = "'{0.25, 0.5, 0.75, 1.0}'::float4[]"
FIELD_SCALE = 4.0
CONCEPT_WEIGHTS = "'{1, 1, 1, 1}'::float4[]"  # concepts are unlabelled: each occurrence counts 1

_STATS = """CROSS JOIN LATERAL (
    SELECT count(*) FILTER (WHERE o.success) AS successes,
           count(*) FILTER (WHERE NOT o.success) AS failures,
           count(*) FILTER (WHERE o.success AND o.robot_id = %(robot)s) AS robot_successes,
           count(*) FILTER (WHERE NOT o.success AND o.robot_id = %(robot)s) AS robot_failures
    FROM outcomes o
    WHERE o.scope = v.scope AND o.process_id = v.process_id AND o.version = v.version
) s"""
_COLUMNS = (
    "v.process_id, v.version, p.current_version, v.title, v.task_pattern, v.tags, v.markdown, "
    "v.created_at, v.saved_by, s.successes, s.failures, s.robot_successes, s.robot_failures"
)
_CURRENT = (
    "FROM processes p JOIN process_versions v ON v.scope = p.scope "
    "AND v.process_id = p.process_id AND v.version = p.current_version " + _STATS
)


def search_terms(terms: tuple[str, ...]) -> list[str]:
    """Distinct non-empty terms, whitespace collapsed: each becomes one ``phraseto_tsquery``
    (a bound parameter, read as plain text: no operator in it means anything)."""
    return list(dict.fromkeys(" ".join(term.split()) for term in terms if term.strip()))


# BM25 in SQL. Each distinct query term is its own tsquery: words ('english' stemming) against
# ``document``, concepts ('simple') against ``concepts``. ``matches`` holds every (term, process)
# match of the scope, found through the GIN indexes, with ``f``, the term's field-weighted
# frequency in that process. Per term, df = its number of matches and idf = ln(1 + (N − df +
# 0.5) / (df + 0.5)) (N: the scope's processes; Lucene's form, positive for every df, so tiny
# stores rank too). A process scores Σ weight · idf · f · (k1 + 1) / (f + k1 · (1 − b + b · dl /
# avgdl)) over the terms it matches (dl: its ``document_length``, avgdl: the scope's mean; weight:
# 1 for words, the query's concept weight for concepts). So a word that few processes contain
# outweighs one most of them share, and repeating a word saturates.
_SEARCH = (
    "WITH terms AS ("  # noqa: S608 - constant SQL, every value is a bound parameter
    "SELECT DISTINCT 'w' AS field, phraseto_tsquery('english', t) AS q "
    "FROM unnest(%(words)s::text[]) AS t UNION "
    "SELECT DISTINCT 'c', phraseto_tsquery('simple', t) FROM unnest(%(concepts)s::text[]) AS t), "
    "usable AS (SELECT row_number() OVER () AS term, field, q FROM terms WHERE numnode(q) > 0), "
    "matches AS MATERIALIZED ("
    "SELECT u.term, p.process_id, p.document_length AS dl, 1.0::float8 AS weight, "
    f"{FIELD_SCALE} * ts_rank_cd({FIELD_WEIGHTS}, p.document, u.q, 0)::float8 AS f "
    "FROM usable u JOIN processes p ON p.document @@ u.q "
    "WHERE u.field = 'w' AND p.scope = %(scope)s "
    "UNION ALL SELECT u.term, p.process_id, p.document_length, %(concept_weight)s::float8, "
    f"ts_rank_cd({CONCEPT_WEIGHTS}, p.concepts, u.q, 0)::float8 "
    "FROM usable u JOIN processes p ON p.concepts @@ u.q "
    "WHERE u.field = 'c' AND p.scope = %(scope)s), "
    "corpus AS (SELECT count(*)::float8 AS n, greatest(avg(document_length), 1)::float8 AS avgdl "
    "FROM processes WHERE scope = %(scope)s), "
    "idf AS (SELECT m.term, ln(1 + (c.n - count(*) + 0.5) / (count(*) + 0.5)) AS idf "
    "FROM matches m CROSS JOIN corpus c GROUP BY m.term, c.n), "
    "hits AS (SELECT m.process_id, sum(m.weight * i.idf * m.f * (%(k1)s + 1) "
    "/ (m.f + %(k1)s * (1 - %(b)s + %(b)s * m.dl / c.avgdl))) AS relevance "
    "FROM matches m JOIN idf i ON i.term = m.term CROSS JOIN corpus c "
    "GROUP BY m.process_id ORDER BY relevance DESC, m.process_id LIMIT %(limit)s) "
    f"SELECT h.relevance, {_COLUMNS} FROM hits h "
    "JOIN processes p ON p.scope = %(scope)s AND p.process_id = h.process_id "
    "JOIN process_versions v ON v.scope = p.scope AND v.process_id = p.process_id "
    f"AND v.version = p.current_version {_STATS} "
    "ORDER BY h.relevance DESC, h.process_id"
)


def _cannot_open(exc: BaseException) -> str:
    return f"cannot open the PostgreSQL process store: {_first_line(exc)}"


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


class PostgresProcessStore(ProcessStore):
    """Process store in a PostgreSQL database; thread-safe through a connection pool."""

    def __init__(
        self,
        dsn: str,
        robot_id: str,
        *,
        visibility: Visibility = "fleet",
        pool_size: int = 8,
        connect_timeout_s: float = 5.0,
    ) -> None:
        self.scope = scope_of(robot_id, visibility)
        self.robot_id = robot_id
        self.visibility = visibility
        timeout = max(1, round(connect_timeout_s))
        try:
            with psycopg.connect(dsn, connect_timeout=timeout) as conn:
                migrate(conn)
        except psycopg.ProgrammingError as exc:
            raise StoreError(
                "the PostgreSQL DSN is not a valid libpq connection string or URI"
            ) from exc
        except psycopg.Error as exc:
            raise StoreError(
                f"cannot open the PostgreSQL process store: {_first_line(exc)}"
            ) from exc
        self._pool: ConnectionPool[Connection] = ConnectionPool(
            dsn,
            min_size=1,
            max_size=pool_size,
            kwargs={"connect_timeout": timeout},
            timeout=connect_timeout_s,
            open=False,
            name=f"memory-{robot_id}",
        )
        try:
            self._pool.open(wait=True, timeout=connect_timeout_s)
        except psycopg.Error as exc:
            self._pool.close()
            raise StoreError(
                f"cannot open the PostgreSQL process store: {_first_line(exc)}"
            ) from exc

    # -- plumbing -------------------------------------------------------------------------

    def _run(self, what: str, work: Callable[[Connection], T]) -> T:
        """``work`` in one transaction (committed when it returns, rolled back if it raises)."""
        try:
            with self._pool.connection() as conn:
                return work(conn)
        except psycopg.Error as exc:
            raise StoreError(f"{what} failed: {_first_line(exc)}") from exc

    def _params(self, **values: Any) -> dict[str, Any]:
        return {"scope": self.scope, "robot": self.robot_id, **values}

    def close(self) -> None:
        self._pool.close()

    # -- port -------------------------------------------------------------------------------

    def save(self, document: ProcessDocument) -> SaveResult:
        def work(conn: Connection) -> SaveResult:
            now = time.time()
            params = self._params(id=document.id, now=now)
            conn.execute(
                "INSERT INTO processes (scope, process_id, current_version, created_at, "
                "updated_at) VALUES (%(scope)s, %(id)s, 0, %(now)s, %(now)s) "
                "ON CONFLICT (scope, process_id) DO NOTHING",
                params,
            )
            head = conn.execute(
                "SELECT current_version FROM processes "
                "WHERE scope = %(scope)s AND process_id = %(id)s FOR UPDATE",
                params,
            ).fetchone()
            current_version = int(head[0]) if head else 0
            if current_version > 0:
                current = self._get(conn, document.id, None)
                if current.markdown == document.markdown:
                    return SaveResult(process=current, created=False)
            params.update(
                version=current_version + 1,
                title=document.title,
                task_pattern=document.task_pattern,
                tags=" ".join(document.tags),
                tag_list=list(document.tags),
                body=document.body,
                markdown=document.markdown,
                concepts=document_concepts(
                    document.title, document.task_pattern, document.tags, document.body
                ),
            )
            conn.execute(
                "INSERT INTO process_versions (scope, process_id, version, saved_by, title, "
                "task_pattern, tags, body, markdown, created_at) VALUES (%(scope)s, %(id)s, "
                "%(version)s, %(robot)s, %(title)s, %(task_pattern)s, %(tag_list)s, %(body)s, "
                "%(markdown)s, %(now)s)",
                params,
            )
            conn.execute(
                "UPDATE processes SET current_version = %(version)s, updated_at = %(now)s, "  # noqa: S608 - constant SQL
                f"document = {DOCUMENT_VECTOR}, concepts = {CONCEPT_VECTOR} "
                "WHERE scope = %(scope)s AND process_id = %(id)s",
                params,
            )
            return SaveResult(process=self._get(conn, document.id, None), created=True)

        return self._run(f"saving process '{document.id}'", work)

    def get(self, process_id: str, version: int | None = None) -> StoredProcess:
        return self._run("reading a process", lambda conn: self._get(conn, process_id, version))

    def list_processes(self) -> list[ProcessSummary]:
        def work(conn: Connection) -> list[ProcessSummary]:
            rows = conn.execute(
                f"SELECT {_COLUMNS}, p.updated_at {_CURRENT} "
                "WHERE p.scope = %(scope)s ORDER BY p.updated_at DESC, p.process_id",
                self._params(),
            ).fetchall()
            return [ProcessSummary.of(_stored(row[:-1]), float(row[-1])) for row in rows]

        return self._run("listing processes", work)

    def search(self, query: SearchQuery, limit: int) -> list[Candidate]:
        if query.empty or limit <= 0:
            return []
        params = self._params(
            words=search_terms(query.words),
            concepts=search_terms(query.concepts) if query.concept_weight > 0 else [],
            concept_weight=query.concept_weight,
            k1=BM25_K1,
            b=BM25_B,
            limit=limit,
        )

        def work(conn: Connection) -> list[Candidate]:
            rows = conn.execute(_SEARCH, params).fetchall()
            return [
                Candidate(process=_stored(row[1:]), relevance=max(float(row[0]), 0.0))
                for row in rows
            ]

        return self._run("searching processes", work)

    def record_outcome(self, process_id: str, success: bool, note: str) -> StoredProcess:
        def work(conn: Connection) -> StoredProcess:
            params = self._params(id=process_id, success=success, note=note, now=time.time())
            head = conn.execute(
                "SELECT current_version FROM processes "
                "WHERE scope = %(scope)s AND process_id = %(id)s FOR SHARE",
                params,
            ).fetchone()
            if head is None or int(head[0]) < 1:
                raise ProcessNotFoundError(process_id)
            conn.execute(
                "INSERT INTO outcomes (scope, process_id, version, robot_id, success, note, "
                "recorded_at) VALUES (%(scope)s, %(id)s, %(version)s, %(robot)s, %(success)s, "
                "%(note)s, %(now)s)",
                {**params, "version": int(head[0])},
            )
            return self._get(conn, process_id, None)

        return self._run(f"recording an outcome for '{process_id}'", work)

    def recent_outcomes(
        self, process_id: str, version: int | None = None, limit: int = 5
    ) -> list[OutcomeRecord]:
        def work(conn: Connection) -> list[OutcomeRecord]:
            target = self._get(conn, process_id, version).version
            rows = conn.execute(
                "SELECT version, success, note, recorded_at, robot_id FROM outcomes "
                "WHERE scope = %(scope)s AND process_id = %(id)s AND version = %(version)s "
                "ORDER BY id DESC LIMIT %(limit)s",
                self._params(id=process_id, version=target, limit=limit),
            ).fetchall()
            return [
                OutcomeRecord(
                    version=int(row[0]),
                    success=bool(row[1]),
                    note=str(row[2]),
                    recorded_at=float(row[3]),
                    robot_id=str(row[4]),
                )
                for row in rows
            ]

        return self._run("reading outcomes", work)

    # -- helpers ----------------------------------------------------------------------------

    def _get(self, conn: Connection, process_id: str, version: int | None) -> StoredProcess:
        row = conn.execute(
            f"SELECT {_COLUMNS} FROM processes p JOIN process_versions v "  # noqa: S608 - constant SQL
            f"ON v.scope = p.scope AND v.process_id = p.process_id {_STATS} "
            "WHERE p.scope = %(scope)s AND p.process_id = %(id)s "
            "AND v.version = coalesce(%(version)s::integer, p.current_version)",
            self._params(id=process_id, version=version),
        ).fetchone()
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
        tags=tuple(row[5]),
        markdown=str(row[6]),
        created_at=float(row[7]),
        saved_by=str(row[8]),
        stats=OutcomeStats(successes=int(row[9]), failures=int(row[10])),
        robot_stats=OutcomeStats(successes=int(row[11]), failures=int(row[12])),
    )
