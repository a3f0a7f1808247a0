"""Every statement of the episodic store, written once with SQLAlchemy Core.

:class:`EpisodicStatements` compiles them for one dialect (SQLite or PostgreSQL) and caches
the SQL text per shape (a query with three labels is another text than one with two), so a
query costs a dict lookup, not a compilation; the adapters run the text on their own driver
connections. Every value is a named bound parameter; the names are the columns' for inserts.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import sqlalchemy as sa
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.engine import Dialect
from sqlalchemy.sql.compiler import SQLCompiler

from robot_mcp_episodic.store.base import Kind
from robot_mcp_episodic.store.schema import EpisodicTables

Insert = sqlite.Insert | postgresql.Insert
InsertFactory = Callable[[sa.Table], Insert]
Interval = Literal["sightings", "visits"]
param = sa.bindparam

_SIGHTING_UPDATES = (
    "last_seen", "count", "best_score", "box", "absent_since", "place", "x", "y", "yaw",
)  # fmt: skip
# Start and end column of the interval tables, and the names of their indexes on each.
_SPAN: dict[Interval, tuple[str, str, str, str]] = {
    "sightings": ("first_seen", "last_seen", "by_start", "by_time"),
    "visits": ("arrived", "departed", "by_arrival", "by_time"),
}


# Constant limits written into the SQL: a bound one would leave PostgreSQL's generic plan of a
# prepared statement guessing how many rows are wanted (measured: pose_near 0.5 -> 0.9 ms).
_ONE: sa.ColumnElement[int] = sa.literal_column("1")
_TWENTY: sa.ColumnElement[int] = sa.literal_column("20")


@dataclass(frozen=True)
class Statement:
    sql: str
    constants: Mapping[str, Any]  # values Core bound itself (e.g. the OFFSET 0 of SQLite)

    def params(self, values: Mapping[str, Any]) -> Mapping[str, Any]:
        return {**self.constants, **values} if self.constants else values


def numbered(prefix: str, values: Sequence[Any]) -> dict[str, Any]:
    """Parameters for :meth:`EpisodicStatements` lists: ``{prefix_0: values[0], ...}``."""
    return {f"{prefix}_{index}": value for index, value in enumerate(values)}


def _one_of(column: sa.ColumnElement[Any], prefix: str, count: int) -> sa.ColumnElement[bool]:
    return column.in_([param(f"{prefix}_{index}") for index in range(count)])


def _hint(query: sa.Select[Any], table: sa.Table, index: str) -> sa.Select[Any]:
    """Name the index SQLite must use (ignored elsewhere): its planner sometimes picks one that
    walks the whole history."""
    return query.with_hint(table, f"INDEXED BY {table.name}_{index}", "sqlite")


class EpisodicStatements:
    def __init__(self, tables: EpisodicTables, dialect: Dialect, insert: InsertFactory) -> None:
        self.tables = tables
        self.dialect = dialect
        self._insert = insert
        self._cache: dict[Hashable, Statement] = {}

    def compiled(
        self, key: Hashable, build: Callable[[], sa.ClauseElement], columns: Sequence[str] = ()
    ) -> Statement:
        """``build()`` compiled for this dialect, once per ``key``; ``columns``: an insert's."""
        statement = self._cache.get(key)
        if statement is None:
            compiled = build().compile(dialect=self.dialect, column_keys=list(columns) or None)
            assert isinstance(compiled, SQLCompiler)
            constants = {
                name: compiled.params[name]
                for bind, name in compiled.bind_names.items()
                if not bind.required
            }
            statement = self._cache[key] = Statement(str(compiled), constants)
        return statement

    def _mine(self, table: sa.Table) -> sa.Select[Any]:
        """This robot's rows of ``table``."""
        return sa.select(*self.tables.row(table)).where(table.c.robot_id == param("robot_id"))

    # -- writes ------------------------------------------------------------------------------
    def save_sightings(self) -> Statement:
        def build() -> sa.ClauseElement:
            insert = self._insert(self.tables.sightings)
            updates = {name: insert.excluded[name] for name in _SIGHTING_UPDATES}
            return insert.on_conflict_do_update(index_elements=["id"], set_=updates)

        return self.compiled("save_sightings", build, self.tables.row_names("sightings"))

    def save_poses(self) -> Statement:
        columns = [name for name in self.tables.row_names("poses") if name != "id"]
        # inline(): no RETURNING of the serial key, which nobody reads.
        return self.compiled(
            "save_poses", lambda: self._insert(self.tables.poses).inline(), columns
        )

    def save_notes(self) -> Statement:
        def build() -> sa.ClauseElement:
            return self._insert(self.tables.notes).on_conflict_do_nothing(index_elements=["id"])

        return self.compiled("save_notes", build, self.tables.row_names("notes"))

    def save_visits(self) -> Statement:
        def build() -> sa.ClauseElement:
            insert = self._insert(self.tables.visits)
            return insert.on_conflict_do_update(
                index_elements=["id"], set_={"departed": insert.excluded.departed}
            )

        return self.compiled("save_visits", build, self.tables.row_names("visits"))

    def record_audit(self) -> Statement:
        columns = ("robot_id", "t", "request", "result")
        return self.compiled("audit", lambda: sa.insert(self.tables.forget_audit).inline(), columns)

    def delete_ids(self, kind: Kind, count: int) -> Statement:
        table = self.tables.of(kind)
        return self.compiled(
            ("delete_ids", kind, count),
            lambda: sa.delete(table).where(
                table.c.robot_id == param("robot_id"), _one_of(table.c.id, "id", count)
            ),
        )

    def delete_before(self, kind: Kind) -> Statement:
        table = self.tables.of(kind)
        return self.compiled(
            ("delete_before", kind),
            lambda: sa.delete(table).where(
                table.c.robot_id == param("robot_id"),
                self.tables.time_column(kind) < param("before"),
            ),
        )

    # -- reads -------------------------------------------------------------------------------
    def labels(self) -> Statement:
        sightings = self.tables.sightings
        return self.compiled(
            "labels",
            lambda: (
                sa.select(sightings.c.label)
                .distinct()
                .where(sightings.c.robot_id == param("robot_id"))
                .order_by(sightings.c.label)
            ),
        )

    def latest_sighting(self) -> Statement:
        sightings = self.tables.sightings
        return self.compiled(
            "latest_sighting",
            lambda: (
                self._mine(sightings)
                .where(sightings.c.skill == param("skill"), sightings.c.label == param("label"))
                .order_by(sightings.c.last_seen.desc())
                .limit(_ONE)
            ),
        )

    def sightings(self, labels: int | None, at_place: bool, newest_first: bool) -> Statement:
        """Intervals overlapping ``[start, end]``: ``labels`` parameters ``label_<i>``
        (:func:`numbered`), or none for any label; ``place`` if ``at_place``."""

        def build() -> sa.ClauseElement:
            s = self.tables.sightings
            query = self._mine(s).where(
                s.c.last_seen >= param("start"), s.c.first_seen <= param("end")
            )
            if labels is not None:
                query = query.where(_one_of(s.c.label, "label", labels))
            if at_place:
                query = query.where(s.c.place == param("place"))
            order = s.c.last_seen.desc() if newest_first else s.c.first_seen.asc()
            # With a few labels and a long window SQLite's planner otherwise takes the start
            # index, walks every older interval and sorts (measured: 2 ms -> 10 ms at 100 h).
            index = "by_label" if labels is not None else "by_time"
            return _hint(query.order_by(order).limit(param("limit")), s, index)

        return self.compiled(("sightings", labels, at_place, newest_first), build)

    def began_inside(self, kind: Interval, at_place: bool) -> Statement:
        """Rows of ``kind`` that began in ``[start, end]``, the latest start first (an index
        range scan on the start)."""
        table = self.tables.of(kind)
        began, _, start_index, _ = _SPAN[kind]

        def build() -> sa.ClauseElement:
            query = self._mine(table).where(
                table.c[began] >= param("start"), table.c[began] <= param("end")
            )
            return _hint(self._latest_start(query, table, began, at_place), table, start_index)

        return self.compiled(("began_inside", kind, at_place), build)

    def began_before(self, kind: Interval, at_place: bool) -> Statement:
        """Rows of ``kind`` that began before ``start`` and were still going at it, the latest
        start first (an index range scan on the end, from ``start`` on)."""
        table = self.tables.of(kind)
        began, ended, _, end_index = _SPAN[kind]

        def build() -> sa.ClauseElement:
            query = self._mine(table).where(
                table.c[ended] >= param("start"), table.c[began] < param("start")
            )
            return _hint(self._latest_start(query, table, began, at_place), table, end_index)

        return self.compiled(("began_before", kind, at_place), build)

    @staticmethod
    def _latest_start(
        query: sa.Select[Any], table: sa.Table, began: str, at_place: bool
    ) -> sa.Select[Any]:
        if at_place:
            query = query.where(table.c.place == param("place"))
        return query.order_by(table.c[began].desc()).limit(param("limit"))

    def notes_in_window(self, at_place: bool) -> sa.Select[Any]:
        """This robot's notes in ``[start, end]`` (at ``place``): what the adapters' full-text
        searches narrow down."""
        n = self.tables.notes
        query = self._mine(n).where(n.c.t >= param("start"), n.c.t <= param("end"))
        return query.where(n.c.place == param("place")) if at_place else query

    def notes(self, kinds: int | None, at_place: bool, newest_first: bool) -> Statement:
        """Notes in ``[start, end]``: ``kinds`` parameters ``kind_<i>``, or none for any."""

        def build() -> sa.ClauseElement:
            n = self.tables.notes
            query = self.notes_in_window(at_place)
            if kinds is not None:
                query = query.where(_one_of(n.c.kind, "kind", kinds))
            order = n.c.t.desc() if newest_first else n.c.t.asc()
            return query.order_by(order).limit(param("limit"))

        return self.compiled(("notes", kinds, at_place, newest_first), build)

    def poses(self) -> Statement:
        p = self.tables.poses
        return self.compiled(
            "poses",
            lambda: (
                self._mine(p)
                .where(p.c.t >= param("start"), p.c.t <= param("end"))
                .order_by(p.c.t)
                .limit(param("limit"))
            ),
        )

    def pose_before(self) -> Statement:
        """The newest sample at or before ``t``."""
        p = self.tables.poses
        return self.compiled(
            "pose_before",
            lambda: self._mine(p).where(p.c.t <= param("t")).order_by(p.c.t.desc()).limit(_ONE),
        )

    def pose_after(self) -> Statement:
        """The oldest sample after ``t``."""
        p = self.tables.poses
        return self.compiled(
            "pose_after",
            lambda: self._mine(p).where(p.c.t > param("t")).order_by(p.c.t).limit(_ONE),
        )

    def kind_stats(self, kind: Kind) -> Statement:
        table, column = self.tables.of(kind), self.tables.time_column(kind)
        return self.compiled(
            ("kind_stats", kind),
            lambda: sa.select(sa.func.count(), sa.func.min(column), sa.func.max(column)).where(
                table.c.robot_id == param("robot_id")
            ),
        )

    def recent_audit(self) -> Statement:
        audit = self.tables.forget_audit
        return self.compiled(
            "recent_audit",
            lambda: (
                sa.select(audit.c.t, audit.c.request, audit.c.result)
                .where(audit.c.robot_id == param("robot_id"))
                .order_by(audit.c.t.desc())
                .limit(_TWENTY)
            ),
        )
