"""Second-stage lexical re-ranking: how much of the request does a candidate cover?

The store's text score (BM25 on both stores) adds up term matches, so a document that repeats one
common word of the request ("take", "room") can beat the one that matches every distinctive
part of it through synonyms. This stage looks at each candidate of the store's pool (the
adapter-independent part of ranking, so SQLite and PostgreSQL rank alike) and scores, for every
content term of the request::

    match(term, doc) = field weight × how it matched
        field weight: title, task pattern or tags 1.0, body 0.5
        how:          same Snowball stem 1.0, same synonym concept 0.8,
                      trigram similarity ≥ 0.5 to a word of the field (typos, compounds)
                      → 0.6 × similarity
    coverage(doc)    = Σ idf(term) · match(term, doc) / Σ idf(term)
    idf(term)        = ln(1 + N / (1 + df)),  df = candidates matching the term, N = pool size

and blends ``relevance = (1 − γ) · r / max(r) + γ · coverage`` (γ = ``MEMORY_COVERAGE_WEIGHT``,
default 0.5). Terms found in most candidates weigh little, a term only the right document
matches weighs most. Per-document analysis is cached by (id, version): versions never change.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache

from robot_mcp_memory.query import QueryTerm, concepts, query_terms, stem, words
from robot_mcp_memory.store.base import Candidate, StoredProcess

STEM_MATCH = 1.0
CONCEPT_MATCH = 0.8
FUZZY_MATCH = 0.6
FUZZY_THRESHOLD = 0.5
BODY_WEIGHT = 0.5
MIN_FUZZY_CHARS = 5  # shorter words have too few trigrams to compare


@dataclass(frozen=True)
class _Field:
    stems: frozenset[str]
    concepts: frozenset[str]
    words: frozenset[str]
    weight: float


@lru_cache(maxsize=65_536)
def trigrams(word: str) -> frozenset[str]:
    padded = f"  {word} "
    return frozenset(padded[index : index + 3] for index in range(len(padded) - 2))


def trigram_similarity(left: str, right: str) -> float:
    """pg_trgm's similarity: shared trigrams over all distinct trigrams of both words."""
    a, b = trigrams(left), trigrams(right)
    return len(a & b) / len(a | b) if a or b else 0.0


def _field(text: str, weight: float, with_concepts: bool = True) -> _Field:
    tokens = words(text)
    return _Field(
        stems=frozenset(stem(token) for token in tokens),
        concepts=frozenset(concepts(text)) if with_concepts else frozenset(),
        words=frozenset(token for token in tokens if len(token) >= MIN_FUZZY_CHARS),
        weight=weight,
    )


def _analyse(process: StoredProcess) -> tuple[_Field, ...]:
    body = process.markdown.split("\n---", 1)[-1]  # the frontmatter repeats title and pattern
    return (
        _field(f"{process.title}\n{process.task_pattern}\n{' '.join(process.tags)}", 1.0),
        _field(body, BODY_WEIGHT, with_concepts=False),  # as the stores index it
    )


def _exact(term: QueryTerm, fields: tuple[_Field, ...]) -> float:
    """Best stem or synonym-concept match of ``term`` over the fields."""
    best = 0.0
    for field in fields:
        if term.stems and all(part in field.stems for part in term.stems):
            best = max(best, field.weight * STEM_MATCH)
        elif term.concept is not None and term.concept in field.concepts:
            best = max(best, field.weight * CONCEPT_MATCH)
    return best


def _fuzzy(term: QueryTerm, fields: tuple[_Field, ...]) -> float:
    """Best trigram-similarity match of a single word ``term`` over the fields' words."""
    best = 0.0
    for field in fields:
        similarity = max((trigram_similarity(term.text, word) for word in field.words), default=0.0)
        if similarity >= FUZZY_THRESHOLD:
            best = max(best, field.weight * FUZZY_MATCH * similarity)
    return best


def _fuzzy_candidate(term: QueryTerm) -> bool:
    return len(term.text) >= MIN_FUZZY_CHARS and " " not in term.text


class CoverageReranker:
    """Blends the store's relevance with query coverage (see the module docstring)."""

    def __init__(self, weight: float = 0.5, cache_size: int = 8192) -> None:
        if not 0.0 <= weight <= 1.0:
            raise ValueError(f"coverage weight must be within [0, 1], got {weight}")
        self.weight = weight
        self._cache: OrderedDict[tuple[str, int], tuple[_Field, ...]] = OrderedDict()
        self._cache_size = cache_size
        self._lock = threading.Lock()

    def rerank(self, query: str, candidates: Sequence[Candidate]) -> list[Candidate]:
        """The candidates with blended relevance, in the same order."""
        terms = query_terms(query)
        if not candidates or not terms or self.weight == 0.0:
            return list(candidates)
        analysed = [self._analysed(candidate.process) for candidate in candidates]
        matches = [[_exact(term, fields) for term in terms] for fields in analysed]
        # trigram fallback only for words no candidate has (typos, compounds): a word that
        # some candidates contain is a real word, and near-misses of it are other words
        for index, term in enumerate(terms):
            if _fuzzy_candidate(term) and not any(row[index] for row in matches):
                for row, fields in zip(matches, analysed, strict=True):
                    row[index] = _fuzzy(term, fields)
        pool = len(candidates)
        idf = [
            math.log(1.0 + pool / (1.0 + sum(row[index] > 0 for row in matches)))
            for index in range(len(terms))
        ]
        total = sum(idf)
        best = max(candidate.relevance for candidate in candidates)
        blended = []
        for candidate, row in zip(candidates, matches, strict=True):
            coverage = sum(w * m for w, m in zip(idf, row, strict=True)) / total
            lexical = candidate.relevance / best if best > 0 else 0.0
            relevance = (1.0 - self.weight) * lexical + self.weight * coverage
            blended.append(replace(candidate, relevance=relevance))
        return blended

    def _analysed(self, process: StoredProcess) -> tuple[_Field, ...]:
        key = (process.id, process.version)
        with self._lock:
            fields = self._cache.get(key)
            if fields is not None:
                self._cache.move_to_end(key)
                return fields
        fields = _analyse(process)
        with self._lock:
            self._cache[key] = fields
            while len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        return fields
