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

from robot_mcp_memory.store.base import SearchQuery

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
"""
STOP_WORDS = frozenset(_STOP_WORDS_TEXT.split())

# Groups of interchangeable words/phrases in a service robot's missions. A query word in a
# group (or a simple inflection of one) is searched as any member of its group.
SYNONYM_GROUPS: tuple[tuple[str, ...], ...] = (
    ("fetch", "bring", "retrieve", "collect", "grab", "pick up", "obtain"),
    ("deliver", "drop off", "hand over", "take", "carry", "transport", "distribute"),
    ("package", "parcel", "box", "delivery", "shipment", "mail", "post", "letter", "envelope"),
    ("mailroom", "mail room", "post room", "post office", "parcel room"),
    ("navigate", "drive", "move", "travel", "head", "walk", "proceed"),
    ("find", "search", "look for", "locate", "seek", "spot", "detect"),
    ("check", "inspect", "verify", "examine", "monitor", "look at"),
    ("tell", "notify", "inform", "report", "announce", "alert", "let know"),
    ("person", "someone", "somebody", "visitor", "guest", "user", "people"),
    ("reception", "front desk", "lobby", "entrance", "foyer"),
    ("office", "desk", "workspace", "cubicle"),
    ("meeting room", "conference room", "boardroom"),
    ("elevator", "lift"),
    ("door", "doorway", "gate"),
    ("cup", "mug", "glass"),
    ("drink", "beverage", "water", "coffee", "tea"),
    ("trash", "garbage", "rubbish", "waste", "litter", "bin"),
    ("clean", "tidy", "wipe", "vacuum", "sweep"),
    ("patrol", "round", "tour", "inspection"),
    ("escort", "guide", "accompany", "lead", "show the way"),
    ("greet", "welcome", "receive"),
    ("charge", "recharge", "dock", "charging station", "battery"),
    ("medicine", "medication", "pills", "drugs", "prescription"),
    ("food", "meal", "lunch", "dinner", "snack", "breakfast"),
    ("printer", "printout", "print", "document", "paper"),
    ("keys", "key", "keycard", "badge"),
    ("closed", "locked", "shut", "blocked"),
    ("arrive", "reach", "get to"),
    ("wait", "pause", "hold"),
    ("stop", "halt", "abort", "cancel"),
    ("kitchen", "pantry", "break room", "canteen", "cafeteria"),
    ("object", "item", "thing"),
)


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


def _index(groups: tuple[tuple[str, ...], ...]) -> dict[str, str]:
    """Member → concept token of its group ("syn" + the first member without spaces)."""
    index: dict[str, str] = {}
    for group in groups:
        token = "syn" + group[0].replace(" ", "")
        for member in group:
            index.setdefault(member, token)
    return index


_CONCEPTS = _index(SYNONYM_GROUPS)
_LONGEST_MEMBER = max(len(member.split()) for group in SYNONYM_GROUPS for member in group)

# Changes whenever the synonym list does: stores re-derive indexed concepts when it differs.
SYNONYMS_VERSION = hashlib.sha256(repr(SYNONYM_GROUPS).encode()).hexdigest()[:16]


def words(text: str) -> list[str]:
    """Lowercase word tokens of ``text`` (each at most MAX_WORD_CHARS), in order."""
    return [token[:MAX_WORD_CHARS] for token in _WORD_RE.findall(text.lower())]


def _concept_of(word: str) -> str | None:
    for form in _lemmas(word):
        if form in _CONCEPTS:
            return _CONCEPTS[form]
    return None


def _terms(tokens: list[str]) -> list[tuple[str, str | None]]:
    """Tokens with multi-word synonym members ("post room", "pick up") joined into one term,
    each term with its concept token (None for words in no synonym group)."""
    terms: list[tuple[str, str | None]] = []
    index = 0
    while index < len(tokens):
        for size in range(min(_LONGEST_MEMBER, len(tokens) - index), 1, -1):
            rest = tokens[index + 1 : index + size]
            phrase = next(
                (
                    candidate
                    for form in _lemmas(tokens[index])  # "picking up" → "pick up"
                    if (candidate := " ".join([form, *rest])) in _CONCEPTS
                ),
                None,
            )
            if phrase is not None:
                terms.append((" ".join(tokens[index : index + size]), _CONCEPTS[phrase]))
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
    """The concept text a store indexes for a process document."""
    return " ".join(concepts("\n".join([title, task_pattern, " ".join(tags), body])))


def build_query(text: str, *, synonyms: bool = True, concept_weight: float = 0.5) -> SearchQuery:
    """The search query for free text ``text``; empty when it has no word characters.

    ``words``: the text's words and written-out multi-word synonyms ("post room"), minus stop
    words (all of them if nothing else is left). ``concepts`` (when ``synonyms``): the concept
    tokens of those words, matched against the concepts indexed for each document.
    """
    terms = _terms(words(text))
    content = [term for term in terms if term[0] not in STOP_WORDS] or terms
    own: dict[str, None] = {}
    found: dict[str, None] = {}
    for word, concept in content:
        if len(own) >= MAX_QUERY_WORDS:
            break
        own.setdefault(word, None)
        if synonyms and concept is not None:
            found.setdefault(concept, None)
    return SearchQuery(words=tuple(own), concepts=tuple(found), concept_weight=concept_weight)
