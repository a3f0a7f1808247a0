"""The ProcessStore port: versioned process documents of one robot, text search, outcomes.

The embedded adapter is :class:`~robot_mcp_memory.store.sqlite_fts.SqliteFtsProcessStore`; a
fleet adapter (PostgreSQL full-text search, one database shared by many robots) implements the
same port. Everything an adapter needs is in the types below, none of them is SQLite-specific:

- the store is bound to one ``robot_id`` at construction and never returns another robot's data;
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

from robot_mcp_memory.documents import ProcessDocument


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
    """One stored version of a process document."""

    id: str
    version: int
    current_version: int
    title: str
    task_pattern: str
    tags: tuple[str, ...]
    markdown: str
    created_at: float
    stats: OutcomeStats = field(default_factory=OutcomeStats)


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
    stats: OutcomeStats


@dataclass(frozen=True)
class OutcomeRecord:
    version: int
    success: bool
    note: str
    recorded_at: float


@dataclass(frozen=True)
class SearchQuery:
    """A text query. ``words`` are the caller's own words and phrases (lowercase word characters
    and spaces only), matched with stemming against title, task pattern, tags and body.
    ``concepts`` are synonym-concept tokens matched against the concepts indexed for each
    document (:func:`robot_mcp_memory.query.document_concepts`). A document matching anything
    is a candidate, scored ``text_score(words) + concept_weight · text_score(concepts)``."""

    words: tuple[str, ...]
    concepts: tuple[str, ...] = ()
    concept_weight: float = 0.5

    @property
    def empty(self) -> bool:
        return not self.words and not self.concepts


@dataclass(frozen=True)
class Candidate:
    process: StoredProcess
    relevance: float  # adapter text score, ≥ 0, higher is better


class ProcessStore(abc.ABC):
    """Versioned process documents of one robot. Implementations are thread-safe; every call
    is short and blocking (callers run them off the event loop)."""

    robot_id: str

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
        """Every process of this robot (current versions), most recently updated first."""

    @abc.abstractmethod
    def search(self, query: SearchQuery, limit: int) -> list[Candidate]:
        """Up to ``limit`` current versions matching ``query``, best text relevance first."""

    @abc.abstractmethod
    def record_outcome(self, process_id: str, success: bool, note: str) -> StoredProcess:
        """Record an outcome against the current version; returns it with updated stats.
        Raises ProcessNotFoundError."""

    @abc.abstractmethod
    def recent_outcomes(
        self, process_id: str, version: int | None = None, limit: int = 5
    ) -> list[OutcomeRecord]:
        """Latest outcomes of one version (default: current), newest first."""

    def close(self) -> None:  # noqa: B027 - optional hook, a no-op for stores without resources
        """Release connections; the store is unusable afterwards."""
