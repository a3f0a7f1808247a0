"""ProcessMemory: the use cases behind the tools (find, save, get, list, record outcome).

Store calls are blocking and run in a worker thread under a deadline, so the event loop never
waits on SQLite. Every failure the caller can act on is a :class:`MemoryServiceError` with a
stable ``code`` and a sentence saying what to do; results are JSON-ready dicts.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any, TypeVar

import structlog

from robot_mcp_memory.coverage import CoverageReranker
from robot_mcp_memory.documents import DocumentError, parse_process
from robot_mcp_memory.embeddings import EmbeddingReranker
from robot_mcp_memory.query import build_query
from robot_mcp_memory.ranking import DEFAULT_OUTCOME_WEIGHT, DEFAULT_ROBOT_FACTOR, Ranked, rank
from robot_mcp_memory.store.base import (
    ProcessNotFoundError,
    ProcessStore,
    StoredProcess,
    StoreError,
)

MAX_K = 20
MAX_QUERY_CHARS = 4_000
MAX_NOTE_CHARS = 2_000
MAX_LIST = 500

T = TypeVar("T")
log = structlog.get_logger("robot_mcp_memory")


class MemoryServiceError(Exception):
    """A failure reported to the caller as ``{"error": code, "detail": detail}``."""

    def __init__(self, code: str, detail: str) -> None:
        self.code = code
        self.detail = detail
        super().__init__(f"{code}: {detail}")


class ProcessMemory:
    def __init__(
        self,
        store: ProcessStore,
        *,
        reranker: EmbeddingReranker | None = None,
        coverage: CoverageReranker | None = None,
        outcome_weight: float = DEFAULT_OUTCOME_WEIGHT,
        robot_factor: float = DEFAULT_ROBOT_FACTOR,
        candidate_pool: int = 100,
        synonyms: bool = True,
        concept_weight: float = 1.0,
        timeout_s: float = 10.0,
    ) -> None:
        self.store = store
        self.reranker = reranker
        self.coverage = CoverageReranker() if coverage is None else coverage
        self.outcome_weight = outcome_weight
        self.robot_factor = robot_factor
        self.candidate_pool = candidate_pool
        self.synonyms = synonyms
        self.concept_weight = concept_weight
        self.timeout_s = timeout_s

    # -- use cases -----------------------------------------------------------------------------

    async def find(self, query: str, k: int = 3) -> dict[str, Any]:
        if not 1 <= k <= MAX_K:
            raise MemoryServiceError("invalid_argument", f"k must be between 1 and {MAX_K}")
        if len(query) > MAX_QUERY_CHARS:
            raise MemoryServiceError(
                "invalid_argument", f"query is longer than {MAX_QUERY_CHARS} characters"
            )
        started = time.perf_counter()
        ranked = await self._call("find_processes", lambda: self.find_sync(query, k))
        results = [_found(item) for item in ranked]
        log.info(
            "processes_found",
            robot_id=self.store.robot_id,
            k=k,
            results=[{"id": item["id"], "score": item["score"]} for item in results],
            duration_ms=_ms(started),
        )
        return {"query": query, "results": results}

    def find_sync(self, query: str, k: int = 3) -> list[Ranked]:
        """The ranking itself, blocking (used by :meth:`find` and the benchmark)."""
        search = build_query(query, synonyms=self.synonyms, concept_weight=self.concept_weight)
        if search.empty:
            return []
        candidates = self.coverage.rerank(
            query, self.store.search(search, max(self.candidate_pool, k))
        )
        relevances = self.reranker.relevances(query, candidates) if self.reranker else None
        return rank(
            candidates,
            outcome_weight=self.outcome_weight,
            relevances=relevances,
            robot_factor=self.robot_factor,
        )[:k]

    async def save(self, markdown: str) -> dict[str, Any]:
        started = time.perf_counter()
        try:
            document = parse_process(markdown)
        except DocumentError as exc:
            log.info("process_rejected", problems=exc.problems)
            raise MemoryServiceError(
                "invalid_document",
                "the process document was not saved: " + "; ".join(exc.problems) + ". "
                "Fix these and call save_process again with the whole document.",
            ) from exc
        result = await self._call("save_process", lambda: self.store.save(document))
        process = result.process
        log.info(
            "process_saved",
            robot_id=self.store.robot_id,
            process_id=process.id,
            version=process.version,
            created=result.created,
            duration_ms=_ms(started),
        )
        if not result.created:
            message = f"identical to the current version {process.version}; nothing new stored"
        elif process.version == 1:
            message = "saved as a new process"
        else:
            message = (
                f"saved as version {process.version}; versions 1..{process.version - 1} stay "
                "retrievable with get_process(id, version)"
            )
        return {
            "id": process.id,
            "version": process.version,
            "created": result.created,
            "title": process.title,
            "message": message,
        }

    async def get(self, process_id: str, version: int | None = None) -> dict[str, Any]:
        def work() -> tuple[StoredProcess, list[dict[str, Any]]]:
            process = self.store.get(process_id, version)
            outcomes = self.store.recent_outcomes(process_id, process.version)
            return process, [
                {
                    "success": o.success,
                    "note": o.note,
                    "robot_id": o.robot_id,
                    "recorded_at": round(o.recorded_at, 3),
                }
                for o in outcomes
            ]

        process, outcomes = await self._call("get_process", work)
        return {
            **_process_fields(process),
            "current_version": process.current_version,
            "created_at": round(process.created_at, 3),
            "recent_outcomes": outcomes,
            "markdown": process.markdown,
        }

    async def list_processes(self, limit: int = 100, offset: int = 0) -> dict[str, Any]:
        if not 1 <= limit <= MAX_LIST or offset < 0:
            raise MemoryServiceError(
                "invalid_argument", f"limit must be between 1 and {MAX_LIST} and offset ≥ 0"
            )
        summaries = await self._call("list_processes", self.store.list_processes)
        page = summaries[offset : offset + limit]
        return {
            "robot_id": self.store.robot_id,
            "visibility": self.store.visibility,
            "total": len(summaries),
            "offset": offset,
            "processes": [
                {
                    "id": s.id,
                    "title": s.title,
                    "task_pattern": s.task_pattern,
                    "tags": list(s.tags),
                    "current_version": s.current_version,
                    "saved_by": s.saved_by,
                    "successes": s.stats.successes,
                    "failures": s.stats.failures,
                    "robot_successes": s.robot_stats.successes,
                    "robot_failures": s.robot_stats.failures,
                    "updated_at": round(s.updated_at, 3),
                }
                for s in page
            ],
        }

    async def record_outcome(self, process_id: str, success: bool, note: str) -> dict[str, Any]:
        if len(note) > MAX_NOTE_CHARS:
            raise MemoryServiceError(
                "invalid_argument", f"note is longer than {MAX_NOTE_CHARS} characters; shorten it"
            )
        started = time.perf_counter()
        process = await self._call(
            "record_outcome", lambda: self.store.record_outcome(process_id, success, note.strip())
        )
        log.info(
            "outcome_recorded",
            robot_id=self.store.robot_id,
            process_id=process.id,
            version=process.version,
            success=success,
            duration_ms=_ms(started),
        )
        return {**_process_fields(process), "recorded": True}

    # -- plumbing ------------------------------------------------------------------------------

    async def _call(self, operation: str, work: Callable[[], T]) -> T:
        try:
            async with asyncio.timeout(self.timeout_s):
                return await asyncio.to_thread(work)
        except ProcessNotFoundError as exc:
            raise MemoryServiceError(
                "not_found",
                f"no {exc} visible to robot '{self.store.robot_id}' "
                f"({self.store.visibility} visibility); call list_processes or "
                "find_processes to see which ids exist",
            ) from exc
        except TimeoutError as exc:
            log.warning("store_timeout", operation=operation, timeout_s=self.timeout_s)
            raise MemoryServiceError(
                "timeout",
                f"the process store did not answer within {self.timeout_s:g} s; "
                "retry later (a save may still complete: check with get_process)",
            ) from exc
        except StoreError as exc:
            log.error("store_failed", operation=operation, error=str(exc))
            raise MemoryServiceError(
                "store_unavailable", f"the process store failed: {exc}; retry later"
            ) from exc


def _ms(started: float) -> float:
    return round((time.perf_counter() - started) * 1000.0, 3)


def _significant(value: float) -> float:
    """Four significant digits (BM25 of a tiny store is ~1e-6, so no fixed decimals)."""
    return float(f"{value:.4g}")


def _process_fields(process: StoredProcess) -> dict[str, Any]:
    return {
        "id": process.id,
        "version": process.version,
        "title": process.title,
        "task_pattern": process.task_pattern,
        "tags": list(process.tags),
        "saved_by": process.saved_by,
        "successes": process.stats.successes,
        "failures": process.stats.failures,
        "robot_successes": process.robot_stats.successes,
        "robot_failures": process.robot_stats.failures,
    }


def _found(item: Ranked) -> dict[str, Any]:
    process = item.candidate.process
    return {
        **_process_fields(process),
        "score": _significant(item.score),
        "relevance": _significant(item.relevance),
        "outcome_boost": round(item.boost, 4),
        "markdown": process.markdown,
    }
