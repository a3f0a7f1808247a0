"""FakeProcessStore: an in-memory ProcessStore for tests, with failure injection.

Search relevance counts the query's words found as substrings of the title, task pattern, tags
or body (1 each) and its concepts found among the document's concepts (``concept_weight`` each)
— enough for everything above the port.
"""

from __future__ import annotations

import threading
import time

from robot_mcp_memory.documents import ProcessDocument
from robot_mcp_memory.query import concepts
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
)


def _count(records: list[OutcomeRecord]) -> OutcomeStats:
    wins = sum(record.success for record in records)
    return OutcomeStats(successes=wins, failures=len(records) - wins)


class FakeProcessStore(ProcessStore):
    def __init__(self, robot_id: str = "robot-1", visibility: Visibility = "robot") -> None:
        self.robot_id = robot_id
        self.visibility = visibility
        self.versions: dict[str, list[tuple[ProcessDocument, float]]] = {}
        self.outcomes: dict[tuple[str, int], list[OutcomeRecord]] = {}
        self.searches: list[tuple[SearchQuery, int]] = []
        self.fail_with: Exception | None = None  # raised by every call when set
        self.delay_s = 0.0  # every call sleeps this long first (to exercise deadlines)
        self.closed = False
        self._lock = threading.Lock()

    def _enter(self) -> None:
        if self.delay_s:
            time.sleep(self.delay_s)
        if self.fail_with is not None:
            raise self.fail_with
        if self.closed:
            raise StoreError("store is closed")

    def _stored(self, process_id: str, version: int | None) -> StoredProcess:
        history = self.versions.get(process_id)
        if not history or (version is not None and not 1 <= version <= len(history)):
            raise ProcessNotFoundError(process_id, version)
        number = len(history) if version is None else version
        document, created_at = history[number - 1]
        records = self.outcomes.get((process_id, number), [])
        return StoredProcess(
            id=document.id,
            version=number,
            current_version=len(history),
            title=document.title,
            task_pattern=document.task_pattern,
            tags=document.tags,
            markdown=document.markdown,
            created_at=created_at,
            saved_by=self.robot_id,
            stats=_count(records),
            robot_stats=_count([r for r in records if r.robot_id == self.robot_id]),
        )

    def save(self, document: ProcessDocument) -> SaveResult:
        self._enter()
        with self._lock:
            history = self.versions.setdefault(document.id, [])
            if history and history[-1][0].markdown == document.markdown:
                return SaveResult(process=self._stored(document.id, None), created=False)
            history.append((document, time.time()))
            return SaveResult(process=self._stored(document.id, None), created=True)

    def get(self, process_id: str, version: int | None = None) -> StoredProcess:
        self._enter()
        return self._stored(process_id, version)

    def list_processes(self) -> list[ProcessSummary]:
        self._enter()
        summaries = []
        for process_id in self.versions:
            current = self._stored(process_id, None)
            summaries.append(
                ProcessSummary(
                    id=current.id,
                    title=current.title,
                    task_pattern=current.task_pattern,
                    tags=current.tags,
                    current_version=current.version,
                    updated_at=current.created_at,
                    saved_by=current.saved_by,
                    stats=current.stats,
                    robot_stats=current.robot_stats,
                )
            )
        return sorted(summaries, key=lambda summary: -summary.updated_at)

    def search(self, query: SearchQuery, limit: int) -> list[Candidate]:
        self._enter()
        self.searches.append((query, limit))
        candidates = []
        for process_id in self.versions:
            current = self._stored(process_id, None)
            document = self.versions[process_id][-1][0]
            text = " ".join(
                [document.title, document.task_pattern, " ".join(document.tags), document.body]
            ).lower()
            found = set(concepts(text))
            hits = sum(word in text for word in query.words) + query.concept_weight * sum(
                concept in found for concept in query.concepts
            )
            if hits:
                candidates.append(Candidate(process=current, relevance=float(hits)))
        candidates.sort(key=lambda candidate: -candidate.relevance)
        return candidates[:limit]

    def record_outcome(self, process_id: str, success: bool, note: str) -> StoredProcess:
        self._enter()
        current = self._stored(process_id, None)
        key = (process_id, current.version)
        record = OutcomeRecord(current.version, success, note, time.time(), self.robot_id)
        self.outcomes.setdefault(key, []).insert(0, record)
        return self._stored(process_id, None)

    def recent_outcomes(
        self, process_id: str, version: int | None = None, limit: int = 5
    ) -> list[OutcomeRecord]:
        self._enter()
        target = self._stored(process_id, version).version
        return self.outcomes.get((process_id, target), [])[:limit]

    def close(self) -> None:
        self.closed = True
