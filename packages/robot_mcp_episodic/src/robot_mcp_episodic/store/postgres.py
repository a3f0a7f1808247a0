# ruff: noqa: S608 - SQL text is built from constant column lists and %s marks only;
# every value is a bound parameter.
"""PostgreSQL adapter of the episodic store: a fleet's robots share one database, every row
carries its ``robot_id`` and each server reads its own robot's rows. Notes are searched with a
stored English ``tsvector`` (GIN index) ranked by ``ts_rank``; any query term matches."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import psycopg
from psycopg.rows import TupleRow
from psycopg_pool import ConnectionPool

from robot_mcp_episodic.store.base import (
    Deleted,
    EpisodicStore,
    Kind,
    KindStats,
    Note,
    PoseSample,
    ScoredNote,
    Sighting,
    StoreError,
    StoreStats,
    Visit,
)
from robot_mcp_episodic.store.rows import (
    NOTE_COLUMNS,
    POSE_COLUMNS,
    SIGHTING_COLUMNS,
    VISIT_COLUMNS,
    note_from_row,
    note_params,
    pose_from_row,
    pose_params,
    sighting_from_row,
    sighting_params,
    visit_from_row,
    visit_params,
)

T = TypeVar("T")
Connection = psycopg.Connection[TupleRow]
SCHEMA_LOCK = 0x45504953  # pg_advisory_xact_lock key: one migration at a time

SCHEMA = """
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


_TABLE: dict[Kind, tuple[str, str]] = {
    "sightings": ("episodic_sightings", "last_seen"),
    "poses": ("episodic_poses", "t"),
    "notes": ("episodic_notes", "t"),
    "visits": ("episodic_visits", "departed"),
}


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


class PostgresEpisodicStore(EpisodicStore):
    def __init__(
        self, dsn: str, robot_id: str, *, pool_size: int = 4, connect_timeout_s: float = 5.0
    ) -> None:
        self.robot_id = robot_id
        timeout = max(1, round(connect_timeout_s))
        try:
            with psycopg.connect(dsn, connect_timeout=timeout) as conn, conn.transaction():
                conn.execute("SELECT pg_advisory_xact_lock(%s)", (SCHEMA_LOCK,))
                conn.execute(SCHEMA)
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

    def _run(self, work: Callable[[Connection], T]) -> T:
        try:
            with self._pool.connection() as conn, conn.transaction():
                return work(conn)
        except psycopg.Error as exc:
            raise StoreError(f"episodic index failed: {_first_line(exc)}") from exc

    def _rows(self, sql: str, params: Sequence[Any]) -> list[TupleRow]:
        return self._run(lambda conn: conn.execute(sql, params).fetchall())

    # -- writes ----------------------------------------------------------------------------
    def save_sightings(self, sightings: Sequence[Sighting]) -> None:
        if not sightings:
            return
        sql = (
            f"INSERT INTO episodic_sightings ({SIGHTING_COLUMNS}) VALUES "
            f"({', '.join(['%s'] * 15)}) ON CONFLICT (id) DO UPDATE SET "
            "last_seen = excluded.last_seen, count = excluded.count, "
            "best_score = excluded.best_score, box = excluded.box, "
            "absent_since = excluded.absent_since, place = excluded.place, x = excluded.x, "
            "y = excluded.y, yaw = excluded.yaw"
        )
        self._run(
            lambda conn: conn.cursor().executemany(sql, [sighting_params(s) for s in sightings])
        )

    def save_poses(self, poses: Sequence[PoseSample]) -> None:
        if not poses:
            return
        sql = (
            "INSERT INTO episodic_poses (robot_id, map, t, x, y, yaw, place) "
            "VALUES (%s, %s, %s, %s, %s, %s, %s)"
        )
        self._run(lambda conn: conn.cursor().executemany(sql, [pose_params(p) for p in poses]))

    def save_notes(self, notes: Sequence[Note]) -> None:
        if not notes:
            return
        sql = (
            f"INSERT INTO episodic_notes ({NOTE_COLUMNS}) VALUES "
            f"({', '.join(['%s'] * 8)}) ON CONFLICT (id) DO NOTHING"
        )
        self._run(lambda conn: conn.cursor().executemany(sql, [note_params(n) for n in notes]))

    # -- reads -----------------------------------------------------------------------------
    def labels(self) -> list[str]:
        rows = self._rows(
            "SELECT DISTINCT label FROM episodic_sightings WHERE robot_id = %s ORDER BY label",
            (self.robot_id,),
        )
        return [row[0] for row in rows]

    def latest_sighting(self, skill: str, label: str) -> Sighting | None:
        rows = self._rows(
            f"SELECT {SIGHTING_COLUMNS} FROM episodic_sightings WHERE robot_id = %s "
            "AND skill = %s AND label = %s ORDER BY last_seen DESC LIMIT 1",
            (self.robot_id, skill, label),
        )
        return sighting_from_row(rows[0]) if rows else None

    def sightings(
        self,
        start: float,
        end: float,
        *,
        labels: Sequence[str] | None = None,
        place: str | None = None,
        limit: int = 100,
        newest_first: bool = False,
    ) -> list[Sighting]:
        where = "robot_id = %s AND last_seen >= %s AND first_seen <= %s"
        params: list[Any] = [self.robot_id, start, end]
        if labels is not None:
            if not labels:
                return []
            where += " AND label = ANY(%s)"
            params.append(list(labels))
        if place is not None:
            where += " AND place = %s"
            params.append(place)
        order = "last_seen DESC" if newest_first else "first_seen ASC"
        rows = self._rows(
            f"SELECT {SIGHTING_COLUMNS} FROM episodic_sightings WHERE {where} "
            f"ORDER BY {order} LIMIT %s",
            [*params, limit],
        )
        return [sighting_from_row(row) for row in rows]

    def sightings_by_start(
        self, start: float, end: float, *, place: str | None = None, limit: int = 50
    ) -> list[Sighting]:
        rows = self._began_last(
            "episodic_sightings", SIGHTING_COLUMNS, ("first_seen", "last_seen"),
            start, end, place, limit,
        )  # fmt: skip
        return [sighting_from_row(row) for row in rows]

    def _began_last(
        self,
        table: str,
        columns: str,
        span: tuple[str, str],
        start: float,
        end: float,
        place: str | None,
        limit: int,
    ) -> list[TupleRow]:
        """The ``limit`` rows overlapping ``[start, end]`` with the latest start, latest first:
        those that began inside the window (the start index), then, only if fewer than
        ``limit``, those that began before it and were still going at ``start`` (the end
        index) -- two bounded range scans, as in the SQLite adapter."""
        began, ended = span
        at_place = " AND place = %s" if place is not None else ""
        extra = [place] if place is not None else []
        rows = self._rows(
            f"SELECT {columns} FROM {table} WHERE robot_id = %s AND {began} >= %s "
            f"AND {began} <= %s{at_place} ORDER BY {began} DESC LIMIT %s",
            [self.robot_id, start, end, *extra, limit],
        )
        if len(rows) < limit:
            rows += self._rows(
                f"SELECT {columns} FROM {table} WHERE robot_id = %s AND {ended} >= %s "
                f"AND {began} < %s{at_place} ORDER BY {began} DESC LIMIT %s",
                [self.robot_id, start, start, *extra, limit - len(rows)],
            )
        return rows

    def notes(
        self,
        start: float,
        end: float,
        *,
        kinds: Sequence[str] | None = None,
        place: str | None = None,
        limit: int = 100,
        newest_first: bool = False,
    ) -> list[Note]:
        where = "robot_id = %s AND t >= %s AND t <= %s"
        params: list[Any] = [self.robot_id, start, end]
        if kinds is not None:
            if not kinds:
                return []
            where += " AND kind = ANY(%s)"
            params.append(list(kinds))
        if place is not None:
            where += " AND place = %s"
            params.append(place)
        order = "t DESC" if newest_first else "t ASC"
        rows = self._rows(
            f"SELECT {NOTE_COLUMNS} FROM episodic_notes WHERE {where} ORDER BY {order} LIMIT %s",
            [*params, limit],
        )
        return [note_from_row(row) for row in rows]

    def search_notes(
        self,
        terms: Sequence[str],
        start: float,
        end: float,
        *,
        place: str | None = None,
        k: int = 10,
    ) -> list[ScoredNote]:
        if not terms:
            return []
        query = " || ".join(["plainto_tsquery('english', %s)"] * len(terms))
        where = "robot_id = %s AND t >= %s AND t <= %s AND document @@ q.query"
        params: list[Any] = [*terms, self.robot_id, start, end]
        if place is not None:
            where += " AND place = %s"
            params.append(place)
        rows = self._rows(
            f"SELECT {NOTE_COLUMNS}, ts_rank(document, q.query) AS score "
            f"FROM episodic_notes, (SELECT {query} AS query) q WHERE {where} "
            "ORDER BY score DESC, t DESC LIMIT %s",
            [*params, k],
        )
        return [ScoredNote(note_from_row(row[:8]), round(float(row[8]), 4)) for row in rows]

    def poses(self, start: float, end: float, *, limit: int = 10_000) -> list[PoseSample]:
        rows = self._rows(
            f"SELECT {POSE_COLUMNS} FROM episodic_poses WHERE robot_id = %s AND t >= %s "
            "AND t <= %s ORDER BY t LIMIT %s",
            (self.robot_id, start, end, limit),
        )
        return [pose_from_row(row) for row in rows]

    def save_visits(self, visits: Sequence[Visit]) -> None:
        if not visits:
            return
        sql = (
            f"INSERT INTO episodic_visits ({VISIT_COLUMNS}) VALUES (%s, %s, %s, %s, %s, %s) "
            "ON CONFLICT (id) DO UPDATE SET departed = excluded.departed"
        )
        self._run(lambda conn: conn.cursor().executemany(sql, [visit_params(v) for v in visits]))

    def visits(
        self, start: float, end: float, *, place: str | None = None, limit: int = 1000
    ) -> list[Visit]:
        rows = self._began_last(
            "episodic_visits", VISIT_COLUMNS, ("arrived", "departed"), start, end, place, limit
        )
        return [visit_from_row(row) for row in reversed(rows)]

    def pose_near(self, t: float) -> tuple[PoseSample | None, PoseSample | None]:
        before = self._rows(
            f"SELECT {POSE_COLUMNS} FROM episodic_poses WHERE robot_id = %s AND t <= %s "
            "ORDER BY t DESC LIMIT 1",
            (self.robot_id, t),
        )
        after = self._rows(
            f"SELECT {POSE_COLUMNS} FROM episodic_poses WHERE robot_id = %s AND t > %s "
            "ORDER BY t LIMIT 1",
            (self.robot_id, t),
        )
        return (
            pose_from_row(before[0]) if before else None,
            pose_from_row(after[0]) if after else None,
        )

    # -- deletion, retention, status -------------------------------------------------------
    def delete(
        self,
        sighting_ids: Sequence[str],
        note_ids: Sequence[str],
        pose_ids: Sequence[int],
        visit_ids: Sequence[str] = (),
    ) -> Deleted:
        def work(conn: Connection) -> Deleted:
            counts = []
            for table, ids in (
                ("episodic_sightings", list(sighting_ids)),
                ("episodic_poses", list(pose_ids)),
                ("episodic_notes", list(note_ids)),
                ("episodic_visits", list(visit_ids)),
            ):
                cursor = conn.execute(
                    f"DELETE FROM {table} WHERE robot_id = %s AND id = ANY(%s)",
                    (self.robot_id, ids),
                )
                counts.append(cursor.rowcount)
            return Deleted(*counts)

        return self._run(work)

    def delete_before(self, kind: Kind, before: float) -> int:
        table, column = _TABLE[kind]
        return self._run(
            lambda conn: (
                conn.execute(
                    f"DELETE FROM {table} WHERE robot_id = %s AND {column} < %s",
                    (self.robot_id, before),
                ).rowcount
            )
        )

    def record_audit(self, t: float, request: dict[str, Any], result: dict[str, Any]) -> None:
        self._run(
            lambda conn: conn.execute(
                "INSERT INTO episodic_forget_audit (robot_id, t, request, result) "
                "VALUES (%s, %s, %s, %s)",
                (self.robot_id, t, json.dumps(request), json.dumps(result)),
            )
        )

    def stats(self) -> StoreStats:
        def work(conn: Connection) -> StoreStats:
            kinds: dict[str, KindStats] = {}
            size = 0
            for kind, (table, column) in _TABLE.items():
                row = conn.execute(
                    f"SELECT count(*), min({column}), max({column}), "
                    f"pg_total_relation_size('{table}') FROM {table} WHERE robot_id = %s",
                    (self.robot_id,),
                ).fetchone()
                assert row is not None
                kinds[kind] = KindStats(int(row[0]), row[1], row[2])
                size += int(row[3])
            audit = [
                {"t": row[0], "request": json.loads(row[1]), "result": json.loads(row[2])}
                for row in conn.execute(
                    "SELECT t, request, result FROM episodic_forget_audit WHERE robot_id = %s "
                    "ORDER BY t DESC LIMIT 20",
                    (self.robot_id,),
                ).fetchall()
            ]
            return StoreStats(kinds, size, audit)

        return self._run(work)

    def close(self) -> None:
        self._pool.close()
