"""Free text → :class:`SearchQuery`: words minus stop words, widened by a small synonym list.

Nothing of the caller's text reaches a backend query language: only runs of word characters
survive (quotes, ``*``, ``-``, ``NEAR``, parentheses ... are separators or plain words), and the
adapter quotes every term. Stemming (``packages`` → ``package``) is the backend's job (FTS5
``porter`` tokenizer); the synonym list bridges paraphrases stemming cannot ("parcel" ~
"package", "bring" ~ "fetch"). Synonyms work as *concepts*: every member of a group maps to one
concept token (``synpackage``), stores index the concept tokens of each document beside its
text, and a query searches its own words plus its concepts (weighted lower). A document
matching a concept through several synonyms gets BM25's saturating credit for one term, not
one full credit per synonym, and the caller's literal words still rank first.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from functools import lru_cache

import snowballstemmer  # type: ignore[import-untyped]

from robot_mcp_memory.synonyms import SYNONYM_GROUPS

MAX_QUERY_WORDS = 32
MAX_WORD_CHARS = 40

_WORD_RE = re.compile(r"\w+", re.UNICODE)

_STOP_WORDS_TEXT = """
a an the and or but if then so of to in on at by for from with without into onto over under
up down out off about as is are was were be been being am do does did done have has had
i me my mine you your yours we us our he him his she her it its they them their this that
these those there here what which who whom whose when where why how all any some each
please could would can will shall should may might must just also very really now again
let lets ok okay hey hi thanks thank kindly go going get got
s t d ll m re ve don doesn didn isn aren wasn weren won wouldn couldn shouldn
"""
STOP_WORDS = frozenset(_STOP_WORDS_TEXT.split())


def _lemmas(word: str) -> list[str]:
    """The word and crude de-inflections of it, most likely first (for synonym lookup only)."""
    forms = [word]
    if word.endswith(("ies", "ied")) and len(word) > 4:
        forms.append(word[:-3] + "y")
    if word.endswith("es") and len(word) > 3:
        forms.append(word[:-2])
    if word.endswith("s") and len(word) > 3:
        forms.append(word[:-1])
    for suffix in ("ing", "ed"):
        if word.endswith(suffix) and len(word) > len(suffix) + 2:
            stem = word[: -len(suffix)]
            forms.extend([stem, stem + "e"])
            if len(stem) > 2 and stem[-1] == stem[-2]:
                forms.append(stem[:-1])  # dropped → drop
    return forms


_STEMMER = snowballstemmer.stemmer("english")


@lru_cache(maxsize=65_536)
def stem(word: str) -> str:
    """The Snowball (Porter 2) stem of a lowercase word, as PostgreSQL's english config and
    close to FTS5's porter tokenizer."""
    return str(_STEMMER.stemWord(word))


def _stems(phrase: str) -> str:
    return " ".join(stem(word) for word in phrase.split())


def _index(groups: tuple[tuple[str, ...], ...]) -> dict[str, str]:
    """Member (as written, and as stems) → concept token of its group ("syn" + the first
    member without spaces). The first group to claim a form keeps it."""
    index: dict[str, str] = {}
    for group in groups:
        token = "syn" + group[0].replace(" ", "")
        for member in group:
            index.setdefault(member, token)
    for group in groups:
        token = "syn" + group[0].replace(" ", "")
        for member in group:
            index.setdefault(_stems(member), token)
    return index


_CONCEPTS = _index(SYNONYM_GROUPS)
_LONGEST_MEMBER = max(len(member.split()) for group in SYNONYM_GROUPS for member in group)
# First words of multi-word members, as written and as stems: only these can start a phrase.
_PHRASE_STARTS = frozenset(
    form
    for group in SYNONYM_GROUPS
    for member in group
    if " " in member
    for form in (member.split()[0], stem(member.split()[0]))
)

# Changes whenever the synonym list does: stores re-derive indexed concepts when it differs.
CONCEPT_FIELDS = "title task_pattern tags"  # what document_concepts reads (part of the version)
SYNONYMS_VERSION = hashlib.sha256(repr((SYNONYM_GROUPS, CONCEPT_FIELDS)).encode()).hexdigest()[:16]


def words(text: str) -> list[str]:
    """Lowercase word tokens of ``text`` (each at most MAX_WORD_CHARS), in order."""
    return [token[:MAX_WORD_CHARS] for token in _WORD_RE.findall(text.lower())]


@lru_cache(maxsize=65_536)
def _concept_of(word: str) -> str | None:
    for form in _lemmas(word):
        if form in _CONCEPTS:
            return _CONCEPTS[form]
    return _CONCEPTS.get(stem(word))


def _phrase_concept(tokens: list[str]) -> str | None:
    """The concept of a multi-word member written in ``tokens`` ("picking up", "post rooms")."""
    rest = " ".join(tokens[1:])
    for form in _lemmas(tokens[0]):
        phrase = f"{form} {rest}"
        if phrase in _CONCEPTS:
            return _CONCEPTS[phrase]
    return _CONCEPTS.get(_stems(" ".join(tokens)))


@lru_cache(maxsize=65_536)
def _can_start_phrase(token: str) -> bool:
    return any(form in _PHRASE_STARTS for form in _lemmas(token)) or stem(token) in _PHRASE_STARTS


def _terms(tokens: list[str]) -> list[tuple[str, str | None]]:
    """Tokens with multi-word synonym members ("post room", "pick up") joined into one term,
    each term with its concept token (None for words in no synonym group)."""
    terms: list[tuple[str, str | None]] = []
    index = 0
    while index < len(tokens):
        starts_phrase = _can_start_phrase(tokens[index])
        for size in range(min(_LONGEST_MEMBER, len(tokens) - index) if starts_phrase else 1, 1, -1):
            concept = _phrase_concept(tokens[index : index + size])
            if concept is not None:
                terms.append((" ".join(tokens[index : index + size]), concept))
                index += size
                break
        else:
            terms.append((tokens[index], _concept_of(tokens[index])))
            index += 1
    return terms


def concepts(text: str) -> list[str]:
    """Concept tokens of every synonym-group word or phrase in ``text``, one per occurrence
    (what a store indexes so that "parcel" and "package" meet)."""
    return [concept for _, concept in _terms(words(text)) if concept is not None]


def document_concepts(title: str, task_pattern: str, tags: tuple[str, ...], body: str) -> str:
    """The concept text a store indexes for a process document: the concepts of what the
    document is about (title, task pattern, tags). The body is searched by its own words only:
    its steps name generic actions ("take the elevator", "check the label") whose concepts
    would make nearly every document match every request."""
    del body  # part of the signature: adapters pass the whole document
    return " ".join(concepts("\n".join([title, task_pattern, " ".join(tags)])))


@dataclass(frozen=True)
class SearchQuery:
    """A text query. ``words`` are the caller's own words and phrases (lowercase word characters
    and spaces only), matched with stemming against title, task pattern, tags and body.
    ``concepts`` are synonym-concept tokens matched against the concepts indexed for each
    document (:func:`robot_mcp_memory.query.document_concepts`). A document matching anything
    is a candidate, scored ``text_score(words) + concept_weight · text_score(concepts)``."""

    words: tuple[str, ...]
    concepts: tuple[str, ...] = ()
    concept_weight: float = 1.0

    @property
    def empty(self) -> bool:
        return not self.words and not self.concepts


@dataclass(frozen=True)
class QueryTerm:
    """A content word or written-out synonym phrase of a request: its text, the stems of its
    words and its synonym concept (None for words in no group)."""

    text: str
    stems: tuple[str, ...]
    concept: str | None


def query_terms(text: str) -> list[QueryTerm]:
    """The request's distinct terms minus stop words (all of them if nothing else is left),
    at most MAX_QUERY_WORDS."""
    terms = _terms(words(text))
    content = [term for term in terms if term[0] not in STOP_WORDS] or terms
    unique = dict.fromkeys(content)
    return [
        QueryTerm(word, tuple(stem(part) for part in word.split()), concept)
        for word, concept in list(unique)[:MAX_QUERY_WORDS]
    ]


def build_query(text: str, *, synonyms: bool = True, concept_weight: float = 1.0) -> SearchQuery:
    """The search query for free text ``text``; empty when it has no word characters.

    ``words``: the text's words and written-out multi-word synonyms ("post room"), minus stop
    words (all of them if nothing else is left). ``concepts`` (when ``synonyms``): the concept
    tokens of those words, matched against the concepts indexed for each document.
    """
    terms = query_terms(text)
    own = dict.fromkeys(term.text for term in terms)
    found = dict.fromkeys(term.concept for term in terms if synonyms and term.concept)
    return SearchQuery(words=tuple(own), concepts=tuple(found), concept_weight=concept_weight)
