"""Words of a question matched against recorded labels (pure): "the red mug" finds the label
"mug" and "mug" finds "red mug"; plurals fold to singular; filler words are dropped."""

from __future__ import annotations

import re
from collections.abc import Iterable
from difflib import SequenceMatcher

_STOP_WORDS_TEXT = """
a an the my your our their his her its this that these those of in on at to from for
with and or did do does you we i me see saw seen find found where when what which who
last time was were is are be been any some have has had it there here
"""
STOP_WORDS = frozenset(_STOP_WORDS_TEXT.split())
_WORD = re.compile(r"[^\W_]+", re.UNICODE)
# one word for one thing, whichever a detector or a person uses ("the package" asked, a
# "yellow package" or a "parcel" recorded: the brain's recall says "parcel" for both)
_SAME_WORD = {"package": "parcel"}


def singular(word: str) -> str:
    if len(word) > 4 and word.endswith("ies"):
        return word[:-3] + "y"
    if len(word) > 3 and word.endswith(("ses", "xes", "ches", "shes")):
        return word[:-2]
    if len(word) > 3 and word.endswith("s") and not word.endswith("ss"):
        return word[:-1]
    return word


def words(text: str) -> list[str]:
    """Content words of ``text``, lower case, singular, stop words dropped, in order."""
    found = [
        _SAME_WORD.get(word, word)
        for word in (singular(w) for w in _WORD.findall(text.lower()) if w not in STOP_WORDS)
    ]
    return list(dict.fromkeys(found))


def label_matches(label: str, query_words: Iterable[str]) -> float:
    """0..1: how well ``label`` matches the query (1 = every label word is asked for or every
    asked word is in the label; partial overlaps score below 1)."""
    label_set = set(words(label))
    query_set = set(query_words)
    if not label_set or not query_set:
        return 0.0
    common = label_set & query_set
    if not common:
        return 0.0
    if label_set <= query_set or query_set <= label_set:
        return 1.0
    return len(common) / len(label_set | query_set)


def matching_labels(labels: Iterable[str], query: str, threshold: float = 1.0) -> list[str]:
    query_words = words(query)
    return [label for label in labels if label_matches(label, query_words) >= threshold]


def corrected_query(labels: Iterable[str], query: str, cutoff: float = 0.8) -> str | None:
    """``query`` with each word no label holds replaced by the one label word closest to it (a
    typo: "scisors" → "scissor"), or None: no word needed it, a word is too short to correct
    (under 4 letters), or none or several label words are as close. Only words of labels on
    record are ever offered: a correction never invents a thing."""
    vocabulary = sorted({w for label in labels for w in words(label)})
    fixed: list[str] = []
    for word in words(query):
        if word in vocabulary:
            fixed.append(word)
            continue
        if len(word) < 4:
            return None
        scored = sorted(
            ((SequenceMatcher(None, word, v).ratio(), v) for v in vocabulary), reverse=True
        )
        best = [v for ratio, v in scored if ratio >= cutoff and ratio == scored[0][0]]
        if len(best) != 1:
            return None
        fixed.append(best[0])
    return " ".join(fixed) if fixed and fixed != words(query) else None
