"""Fuzzy matching of what people say against the live places and the things they ask for
(rapidfuzz, MIT): one small wrapper, so the scorer and its thresholds live in one place."""

from __future__ import annotations

from collections.abc import Collection, Iterable
from dataclasses import dataclass

from rapidfuzz import fuzz, process

SURE = 85.0  # at or above, and clear of the runner-up by MARGIN: the place meant
ASK = 75.0  # at or above: asked about ("Did you mean the kitchen?"), never driven to
MARGIN = 8.0
MIN_LENGTH = 4  # shorter words are too easy to confuse ("bob" / "box")


@dataclass(frozen=True)
class Near:
    """A candidate spelling and how close it is (0–100)."""

    text: str
    score: float


def nearest(word: str, choices: Iterable[str], cutoff: float = ASK) -> list[Near]:
    """The ``choices`` within ``cutoff`` of ``word`` (Indel similarity), best first."""
    if len(word) < MIN_LENGTH:
        return []
    found = process.extract(word, list(dict.fromkeys(choices)), scorer=fuzz.ratio,
                            score_cutoff=cutoff, limit=5)  # fmt: skip
    return [Near(text, float(score)) for text, score, _ in found]


def clear(found: list[Near]) -> bool:
    """The best of ``found`` is sure: above SURE and clear of the next."""
    if not found or found[0].score < SURE:
        return False
    return len(found) == 1 or found[0].score - found[1].score >= MARGIN


def respelt(phrase: str, things: Collection[str]) -> str:
    """``phrase`` with each word that is clearly a misspelt thing ("scisors") spelt as it."""
    return " ".join(w if w in things or not clear(n := nearest(w, things, SURE)) else n[0].text
                    for w in phrase.split())  # fmt: skip
