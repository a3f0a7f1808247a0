"""The episodic index's tables, declared once for every SQL adapter (SQLAlchemy Core).

The adapters create them with ``CREATE ... IF NOT EXISTS`` compiled for their dialect, so a
database made by an earlier version opens as it is. What only one database has (SQLite's FTS5
table and its triggers, PostgreSQL's stored ``tsvector`` and its GIN index) stays in that
adapter. Column order matches the row conversions in :mod:`.rows`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Dialect
from sqlalchemy.schema import CreateIndex, CreateTable

from robot_mcp_episodic.store.base import Kind

# REAL on SQLite, DOUBLE PRECISION on PostgreSQL: the types the index always had.
REAL: sa.types.TypeEngine[float] = sa.Double().with_variant(sa.REAL(), "sqlite")
# A serial key: BIGSERIAL on PostgreSQL; on SQLite an INTEGER primary key is the rowid.
SERIAL = sa.BigInteger().with_variant(sa.Integer(), "sqlite")


@dataclass(frozen=True)
class EpisodicTables:
    metadata: sa.MetaData
    sightings: sa.Table
    poses: sa.Table
    notes: sa.Table
    visits: sa.Table
    forget_audit: sa.Table

    def of(self, kind: Kind) -> sa.Table:
        table: sa.Table = getattr(self, kind)
        return table

    def row(self, table: sa.Table) -> list[sa.Column[Any]]:
        """The columns every adapter has, in the order of :mod:`.rows`."""
        return [column for column in table.c if not column.info.get(ADAPTER_ONLY)]

    def row_names(self, kind: Kind) -> list[str]:
        return [column.name for column in self.row(self.of(kind))]

    def time_column(self, kind: Kind) -> sa.Column[float]:
        """The column retention and stats read: when a row of ``kind`` ended."""
        return self.of(kind).c[TIME_COLUMN[kind]]

    def ddl(self, dialect: Dialect) -> list[str]:
        """``CREATE TABLE/INDEX IF NOT EXISTS`` for every table, compiled for ``dialect``."""
        statements = []
        for table in self.metadata.sorted_tables:
            statements.append(str(CreateTable(table, if_not_exists=True).compile(dialect=dialect)))
            statements.extend(
                str(CreateIndex(index, if_not_exists=True).compile(dialect=dialect))
                for index in sorted(table.indexes, key=lambda index: str(index.name))
            )
        return statements


ADAPTER_ONLY = "adapter_only"  # Column.info key of a column only one database has

TIME_COLUMN: dict[Kind, str] = {
    "sightings": "last_seen", "poses": "t", "notes": "t", "visits": "departed",
}  # fmt: skip


def _text(name: str, *, nullable: bool = False) -> sa.Column[str]:
    return sa.Column(name, sa.Text, nullable=nullable)


def _real(name: str, *, nullable: bool = False) -> sa.Column[float]:
    return sa.Column(name, REAL, nullable=nullable)


def episodic_tables(prefix: str = "", *notes_extra: sa.Column[Any]) -> EpisodicTables:
    """The tables named ``<prefix>sightings`` etc.; ``notes_extra``: columns only one
    database's notes have (appended after the common ones, left out of rows)."""
    for column in notes_extra:
        column.info[ADAPTER_ONLY] = True
    metadata = sa.MetaData()
    sightings = sa.Table(
        f"{prefix}sightings", metadata,
        sa.Column("id", sa.Text, primary_key=True), _text("robot_id"), _text("map"),
        _text("skill"), _text("label"), _real("first_seen"), _real("last_seen"),
        sa.Column("count", sa.Integer, nullable=False), _real("best_score"),
        _text("box", nullable=True), _real("x", nullable=True), _real("y", nullable=True),
        _real("yaw", nullable=True), _text("place", nullable=True),
        _real("absent_since", nullable=True),
    )  # fmt: skip
    poses = sa.Table(
        f"{prefix}poses", metadata,
        sa.Column("id", SERIAL, primary_key=True), _text("robot_id"), _text("map"), _real("t"),
        _real("x"), _real("y"), _real("yaw"), _text("place", nullable=True),
    )  # fmt: skip
    notes = sa.Table(
        f"{prefix}notes", metadata,
        sa.Column("id", sa.Text, primary_key=True), _text("robot_id"), _text("map"),
        _real("t"), _text("kind"), _text("text"), _text("mission_id", nullable=True),
        _text("place", nullable=True), *notes_extra,
    )  # fmt: skip
    visits = sa.Table(
        f"{prefix}visits", metadata,
        sa.Column("id", sa.Text, primary_key=True), _text("robot_id"), _text("map"),
        _text("place"), _real("arrived"), _real("departed"),
    )  # fmt: skip
    forget_audit = sa.Table(
        f"{prefix}forget_audit", metadata,
        sa.Column("id", SERIAL, primary_key=True), _text("robot_id"), _real("t"),
        _text("request"), _text("result"),
    )  # fmt: skip
    for table, suffix, columns in (
        (sightings, "by_time", ("robot_id", "last_seen")),
        (sightings, "by_label", ("robot_id", "label", "last_seen")),
        (sightings, "by_start", ("robot_id", "first_seen")),
        (poses, "by_time", ("robot_id", "t")),
        (notes, "by_time", ("robot_id", "t")),
        (visits, "by_time", ("robot_id", "departed")),
        (visits, "by_arrival", ("robot_id", "arrived")),
    ):
        sa.Index(f"{table.name}_{suffix}", *(table.c[name] for name in columns))
    return EpisodicTables(metadata, sightings, poses, notes, visits, forget_audit)
