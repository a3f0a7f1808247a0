"""The episodic store over any SQL database: every port method written once on the statements
of :mod:`.statements`. An adapter supplies its connection handling (:meth:`_session`), its
full-text search and its size on disk; see :mod:`.sqlite` and :mod:`.postgres`."""

from __future__ import annotations

import abc
import json
from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from typing import Any

from robot_mcp_episodic.store.base import (
    KINDS,
    Deleted,
    EpisodicStore,
    Kind,
    KindStats,
    Note,
    PoseSample,
    ScoredNote,
    Sighting,
    StoreStats,
    Visit,
)
from robot_mcp_episodic.store.rows import (
    note_from_row,
    note_params,
    pose_from_row,
    pose_params,
    sighting_from_row,
    sighting_params,
    visit_from_row,
    visit_params,
)
from robot_mcp_episodic.store.statements import EpisodicStatements, Interval, Statement, numbered

DELETE_CHUNK = 500  # ids per DELETE (SQLite binds at most 32,766 parameters)


class Session:
    """Statements run on one connection, inside whatever transaction the adapter opened."""

    def __init__(self, connection: Any) -> None:  # a sqlite3 or psycopg connection
        self._connection = connection

    def rows(self, statement: Statement, **params: Any) -> list[Sequence[Any]]:
        return list(self._connection.execute(statement.sql, statement.params(params)).fetchall())

    def count(self, statement: Statement, **params: Any) -> int:
        """Run a DELETE or UPDATE; how many rows it touched."""
        return int(self._connection.execute(statement.sql, statement.params(params)).rowcount)

    def each(self, statement: Statement, params: Sequence[Mapping[str, Any]]) -> None:
        """Run ``statement`` once per parameter set (a batch insert)."""
        batch = [statement.params(values) for values in params]
        self._connection.cursor().executemany(statement.sql, batch)


class SqlEpisodicStore(EpisodicStore, abc.ABC):
    sql: EpisodicStatements

    @abc.abstractmethod
    def _session(self, *, write: bool) -> AbstractContextManager[Session]:
        """A session in a transaction (``write``: one that may write), committed on exit."""

    @abc.abstractmethod
    def _size_bytes(self, session: Session) -> int:
        """What the index takes on disk."""

    @abc.abstractmethod
    def _search(self, terms: Sequence[str], at_place: bool) -> tuple[Statement, dict[str, Any]]:
        """The database's full-text query for notes matching any of ``terms`` (in
        :meth:`EpisodicStatements.notes_in_window`), best first, the score its last column;
        and the parameters that carry ``terms``."""

    @abc.abstractmethod
    def _score(self, raw: Any) -> float:
        """The port's score (higher is better, never negative) of the database's."""

    def _read(self, statement: Statement, params: Mapping[str, Any]) -> list[Sequence[Any]]:
        """One query in a read transaction of its own (an adapter may run it more directly)."""
        with self._session(write=False) as session:
            return session.rows(statement, **params)

    def _rows(self, statement: Statement, **params: Any) -> list[Sequence[Any]]:
        params["robot_id"] = self.robot_id
        return self._read(statement, params)

    def _save(self, statement: Statement, params: Sequence[Mapping[str, Any]]) -> None:
        if params:
            with self._session(write=True) as session:
                session.each(statement, params)

    # -- writes ----------------------------------------------------------------------------
    def save_sightings(self, sightings: Sequence[Sighting]) -> None:
        self._save(self.sql.save_sightings(), [sighting_params(s) for s in sightings])

    def save_poses(self, poses: Sequence[PoseSample]) -> None:
        self._save(self.sql.save_poses(), [pose_params(p) for p in poses])

    def save_notes(self, notes: Sequence[Note]) -> None:
        self._save(self.sql.save_notes(), [note_params(n) for n in notes])

    def save_visits(self, visits: Sequence[Visit]) -> None:
        self._save(self.sql.save_visits(), [visit_params(v) for v in visits])

    # -- reads -----------------------------------------------------------------------------
    def labels(self) -> list[str]:
        return [row[0] for row in self._rows(self.sql.labels())]

    def latest_sighting(self, skill: str, label: str) -> Sighting | None:
        rows = self._rows(self.sql.latest_sighting(), skill=skill, label=label)
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
        if labels is not None and not labels:
            return []
        statement = self.sql.sightings(
            None if labels is None else len(labels), place is not None, newest_first
        )
        rows = self._rows(
            statement, start=start, end=end, place=place, limit=limit,
            **numbered("label", labels or ()),
        )  # fmt: skip
        return [sighting_from_row(row) for row in rows]

    def sightings_by_start(
        self, start: float, end: float, *, place: str | None = None, limit: int = 50
    ) -> list[Sighting]:
        rows = self._began_last("sightings", start, end, place, limit)
        return [sighting_from_row(row) for row in rows]

    def _began_last(
        self, kind: Interval, start: float, end: float, place: str | None, limit: int
    ) -> list[Sequence[Any]]:
        """The ``limit`` rows overlapping ``[start, end]`` with the latest start, latest first,
        in two bounded index range scans: the rows that began inside the window, then, only if
        there are fewer than ``limit``, the ones that began before it and were still going at
        ``start`` (bounded because the window itself held fewer than ``limit``). One
        ``began <= end AND ended >= start`` scan by start would walk the whole older history
        whenever the window holds fewer than ``limit`` rows."""
        at_place = place is not None
        window = {"start": start, "end": end, "place": place}
        rows = self._rows(self.sql.began_inside(kind, at_place), **window, limit=limit)
        if len(rows) < limit:
            rows += self._rows(
                self.sql.began_before(kind, at_place), **window, limit=limit - len(rows)
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
        if kinds is not None and not kinds:
            return []
        statement = self.sql.notes(
            None if kinds is None else len(kinds), place is not None, newest_first
        )
        rows = self._rows(
            statement, start=start, end=end, place=place, limit=limit,
            **numbered("kind", kinds or ()),
        )  # fmt: skip
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
        statement, by_terms = self._search(terms, place is not None)
        rows = self._rows(statement, start=start, end=end, place=place, limit=k, **by_terms)
        return [ScoredNote(note_from_row(row[:-1]), self._score(row[-1])) for row in rows]

    def poses(self, start: float, end: float, *, limit: int = 10_000) -> list[PoseSample]:
        rows = self._rows(self.sql.poses(), start=start, end=end, limit=limit)
        return [pose_from_row(row) for row in rows]

    def visits(
        self, start: float, end: float, *, place: str | None = None, limit: int = 1000
    ) -> list[Visit]:
        rows = self._began_last("visits", start, end, place, limit)
        return [visit_from_row(row) for row in reversed(rows)]

    def pose_near(self, t: float) -> tuple[PoseSample | None, PoseSample | None]:
        before = self._rows(self.sql.pose_before(), t=t)
        after = self._rows(self.sql.pose_after(), t=t)
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
        wanted: dict[Kind, list[Any]] = {
            "sightings": list(sighting_ids), "poses": list(pose_ids),
            "notes": list(note_ids), "visits": list(visit_ids),
        }  # fmt: skip
        counts: dict[Kind, int] = dict.fromkeys(KINDS, 0)
        with self._session(write=True) as session:
            for kind, ids in wanted.items():
                for at in range(0, len(ids), DELETE_CHUNK):
                    chunk = ids[at : at + DELETE_CHUNK]
                    counts[kind] += session.count(
                        self.sql.delete_ids(kind, len(chunk)),
                        robot_id=self.robot_id, **numbered("id", chunk),
                    )  # fmt: skip
        return Deleted(**counts)

    def delete_before(self, kind: Kind, before: float) -> int:
        with self._session(write=True) as session:
            return session.count(
                self.sql.delete_before(kind), robot_id=self.robot_id, before=before
            )

    def record_audit(self, t: float, request: dict[str, Any], result: dict[str, Any]) -> None:
        audit = {"robot_id": self.robot_id, "t": t}
        audit.update(request=json.dumps(request), result=json.dumps(result))
        self._save(self.sql.record_audit(), [audit])

    def stats(self) -> StoreStats:
        with self._session(write=False) as session:
            kinds: dict[str, KindStats] = {}
            for kind in KINDS:
                [row] = session.rows(self.sql.kind_stats(kind), robot_id=self.robot_id)
                kinds[kind] = KindStats(int(row[0]), row[1], row[2])
            audit = [
                {"t": row[0], "request": json.loads(row[1]), "result": json.loads(row[2])}
                for row in session.rows(self.sql.recent_audit(), robot_id=self.robot_id)
            ]
            size = self._size_bytes(session)
        return StoreStats(kinds, size, audit)
