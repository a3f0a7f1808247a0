"""The coverage stage: documents covering more of the request, through synonyms, move up."""

from __future__ import annotations

import pytest

from robot_mcp_memory.coverage import CoverageReranker, trigram_similarity
from robot_mcp_memory.documents import parse_process, render_process
from robot_mcp_memory.store.base import Candidate, StoredProcess


def candidate(process_id: str, title: str, pattern: str, relevance: float) -> Candidate:
    document = parse_process(render_process(process_id, title, pattern, [], ["do it"]))
    process = StoredProcess(
        id=document.id,
        version=1,
        current_version=1,
        title=document.title,
        task_pattern=document.task_pattern,
        tags=document.tags,
        markdown=document.markdown,
        created_at=0.0,
        saved_by="robot-1",
    )
    return Candidate(process=process, relevance=relevance)


def order(candidates: list[Candidate]) -> list[str]:
    return [c.process.id for c in sorted(candidates, key=lambda c: -c.relevance)]


def test_a_document_covering_every_part_through_synonyms_beats_one_repeating_a_word() -> None:
    pool = [
        candidate("take-plant-to-ward", "Take the plant to the patient room", "take a plant", 9.0),
        candidate("deliver-medication", "Deliver medication", "bring medicine to a patient", 7.5),
        candidate("take-chairs", "Take the chairs away", "take chairs out", 8.0),
    ]

    ranked = CoverageReranker(0.5).rerank("take the pills to the patient", pool)

    assert order(ranked)[0] == "deliver-medication"


def test_the_blend_keeps_the_store_order_when_coverage_is_equal() -> None:
    pool = [
        candidate("mail-a", "Fetch the mail", "fetch mail", 4.0),
        candidate("mail-b", "Fetch the mail", "fetch mail", 2.0),
    ]

    ranked = CoverageReranker(0.5).rerank("fetch the mail", pool)

    assert order(ranked) == ["mail-a", "mail-b"]
    assert ranked[0].relevance == pytest.approx(1.0)
    assert ranked[1].relevance == pytest.approx(0.75)


def test_a_typo_still_counts_through_trigram_similarity() -> None:
    pool = [
        candidate("thermostat", "Check the thermostat", "read the thermostat", 1.0),
        candidate("other", "Check the windows", "look at windows", 1.0),
    ]

    ranked = CoverageReranker(1.0).rerank("thermostatt reading", pool)

    assert order(ranked)[0] == "thermostat"
    assert trigram_similarity("thermostatt", "thermostat") > 0.5
    assert trigram_similarity("mailroom", "kitchen") == 0.0


def test_weight_zero_or_an_empty_request_changes_nothing() -> None:
    pool = [candidate("a", "Fetch the mail", "fetch mail", 3.0)]

    assert CoverageReranker(0.0).rerank("fetch the mail", pool) == pool
    assert CoverageReranker(0.5).rerank("", pool) == pool
    assert CoverageReranker(0.5).rerank("anything", []) == []
    with pytest.raises(ValueError, match="coverage weight"):
        CoverageReranker(1.5)


def test_analysed_documents_are_cached_and_bounded() -> None:
    reranker = CoverageReranker(0.5, cache_size=2)
    pool = [candidate(f"doc-{i}", f"Task {i}", "fetch mail", 1.0) for i in range(3)]

    reranker.rerank("fetch mail", pool)
    reranker.rerank("fetch mail", pool[-1:])

    assert list(reranker._cache) == [("doc-1", 1), ("doc-2", 1)]
