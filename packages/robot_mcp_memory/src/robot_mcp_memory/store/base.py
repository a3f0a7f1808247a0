"""The ProcessStore port: versioned process documents, text search, per-robot outcomes.

The embedded adapter is :class:`~robot_mcp_memory.store.sqlite_fts.SqliteFtsProcessStore`; the
fleet adapter :class:`~robot_mcp_memory.store.postgres.PostgresProcessStore` (PostgreSQL full-text
search, one database shared by many robots) implements the same port. Everything an adapter
needs is in the types below, none of them is backend-specific:

- the store is bound to one ``robot_id`` and one :data:`Visibility` at construction. With
  ``robot`` visibility it reads and writes only this robot's processes; with ``fleet`` it
  shares one namespace of process ids with every robot of the fleet (:func:`scope_of`);
- every version records the robot that saved it (``saved_by``); every outcome records the robot
  that reported it, and each version carries its fleet-wide and this robot's outcome counts;
- :meth:`ProcessStore.search` takes a :class:`SearchQuery` (words and synonym concepts, already
  built from free text), never a backend query string, so each adapter renders it in its own
  syntax with its own escaping (FTS5 ``MATCH``, ``to_tsquery`` parameters, ...); adapters index
  :func:`robot_mcp_memory.query.document_concepts` of each current version beside its text;
- ``relevance`` is the adapter's text score (higher is better, ≥ 0); the outcome adjustment in
  :mod:`robot_mcp_memory.ranking` is applied above the port, so every adapter ranks alike.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Literal

from robot_mcp_memory.documents import ProcessDocument
from robot_mcp_memory.query import SearchQuery as SearchQuery  # the port's query, built there

Visibility = Literal["robot", "fleet"]
FLEET_SCOPE = "fleet"


def scope_of(robot_id: str, visibility: Visibility) -> str:
    """The namespace a store reads and writes: ``robot:<id>`` or the fleet's ``fleet``
    (robot scopes always contain a colon, so no robot id can name the fleet's)."""
    if not robot_id.strip():
        raise ValueError("robot_id must not be empty")
    return FLEET_SCOPE if visibility == "fleet" else f"robot:{robot_id}"


class StoreError(RuntimeError):
    """The store failed (I/O, locking, corruption); the request did not take effect."""


class ProcessNotFoundError(KeyError):
    """No process (or no such version of it) for this robot."""

    def __init__(self, process_id: str, version: int | None = None) -> None:
        self.process_id = process_id
        self.version = version
        what = f"process '{process_id}'" + (f" version {version}" if version is not None else "")
        super().__init__(what)

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass(frozen=True)
class OutcomeStats:
    """Recorded outcomes of one version of a process."""

    successes: int = 0
    failures: int = 0

    @property
    def total(self) -> int:
        return self.successes + self.failures


@dataclass(frozen=True)
class StoredProcess:
    """One stored version of a process document. ``stats``: outcomes of this version reported
    by any robot of the scope; ``robot_stats``: those reported by this store's robot."""

    id: str
    version: int
    current_version: int
    title: str
    task_pattern: str
    tags: tuple[str, ...]
    markdown: str
    created_at: float
    saved_by: str
    stats: OutcomeStats = field(default_factory=OutcomeStats)
    robot_stats: OutcomeStats = field(default_factory=OutcomeStats)


@dataclass(frozen=True)
class SaveResult:
    process: StoredProcess
    created: bool  # False when the markdown equals the current version (nothing new stored)


@dataclass(frozen=True)
class ProcessSummary:
    """A process in a listing: its current version, without the markdown."""

    id: str
    title: str
    task_pattern: str
    tags: tuple[str, ...]
    current_version: int
    updated_at: float
    saved_by: str
    stats: OutcomeStats
    robot_stats: OutcomeStats

    @classmethod
    def of(cls, process: StoredProcess, updated_at: float) -> ProcessSummary:
        return cls(
            id=process.id,
            title=process.title,
            task_pattern=process.task_pattern,
            tags=process.tags,
            current_version=process.current_version,
            updated_at=updated_at,
            saved_by=process.saved_by,
            stats=process.stats,
            robot_stats=process.robot_stats,
        )


@dataclass(frozen=True)
class OutcomeRecord:
    version: int
    success: bool
    note: str
    recorded_at: float
    robot_id: str


@dataclass(frozen=True)
class Candidate:
    process: StoredProcess
    relevance: float  # adapter text score, ≥ 0, higher is better


class ProcessStore(abc.ABC):
    """Versioned process documents of one scope (:func:`scope_of`). Implementations are
    thread-safe and keep a consistent version history when several stores (threads, processes,
    robots) save one id at once: each save gets the next version number, none is lost, and
    ``current_version`` is the last one committed. Every call is short and blocking (callers
    run them off the event loop)."""

    robot_id: str
    visibility: Visibility

    @abc.abstractmethod
    def save(self, document: ProcessDocument) -> SaveResult:
        """Store ``document`` as the new current version of its id (version 1 for a new id).
        Older versions stay retrievable. Saving markdown identical to the current version
        stores nothing and returns it with ``created=False``."""

    @abc.abstractmethod
    def get(self, process_id: str, version: int | None = None) -> StoredProcess:
        """The current version, or the given one; raises ProcessNotFoundError."""

    @abc.abstractmethod
    def list_processes(self) -> list[ProcessSummary]:
        """Every process of the scope (current versions), most recently updated first."""

    @abc.abstractmethod
    def search(self, query: SearchQuery, limit: int) -> list[Candidate]:
        """Up to ``limit`` current versions matching ``query``, best text relevance first."""

    @abc.abstractmethod
    def record_outcome(self, process_id: str, success: bool, note: str) -> StoredProcess:
        """Record this robot's outcome against the current version; returns it with updated
        stats. Raises ProcessNotFoundError."""

    @abc.abstractmethod
    def recent_outcomes(
        self, process_id: str, version: int | None = None, limit: int = 5
    ) -> list[OutcomeRecord]:
        """Latest outcomes of one version (default: current), newest first."""

    def close(self) -> None:  # noqa: B027 - optional hook, a no-op for stores without resources
        """Release connections; the store is unusable afterwards."""
