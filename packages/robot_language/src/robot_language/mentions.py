"""The known things a sentence names (issue 38, the entities the check accounts for): places by
their map name, an alias or the name their description gives them ("Bob's desk", "the charging
dock"), a site's word for a place after a word of going ("go home"), and known object labels.
Only whole words said as the map spells them count: a near spelling is never a mention, so the
check never asks about a place nobody named."""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, replace

from robot_language.places import PlaceIndex, key, words

# a site's word for a place ("home", "base") names it only where a place is expected
_GOING = {"to", "at", "from", "back", "go", "head", "return", "towards", "via", "by"}


@dataclass(frozen=True)
class Mention:
    said: str  # the words as the sentence has them ("bob desk")
    name: str  # the map id, or the object label
    label: bool = False  # an object label, not a place


def place_mentions(text: str, places: PlaceIndex | None) -> list[Mention]:
    """The places ``text`` names, in order, the longest spelling first where two overlap."""
    if places is None or not places.places:
        return []
    spellings: dict[tuple[str, ...], str] = {}
    for place in places.places:
        for spelled in (*place.spellings(), key(place.spoken())):
            said = tuple(w for w in spelled.split() if w != "the")
            if said:
                spellings.setdefault(said, place.name)
    found = _spans(words(text), spellings)
    tokens = words(text)
    for i, word in enumerate(tokens):
        if word in places.place_words and i > 0 and tokens[i - 1] in _GOING:
            match = places.resolve(word)
            if match.sure and not any(m.name == match.names[0] for m in found):
                found.append(Mention(word, match.names[0]))
    return found


def object_mentions(text: str, labels: Collection[str]) -> list[Mention]:
    """The known object labels ``text`` names (a label of several words as a whole)."""
    spellings = {tuple(words(label)): label for label in labels if words(label)}
    return [replace(m, label=True) for m in _spans(words(text), spellings)]


def _spans(tokens: list[str], spellings: dict[tuple[str, ...], str]) -> list[Mention]:
    """Each run of ``tokens`` that is one of ``spellings``; a longer run wins an overlap."""
    found: list[tuple[int, Mention]] = []
    taken: set[int] = set()
    for said in sorted(spellings, key=len, reverse=True):
        n = len(said)
        for i in range(len(tokens) - n + 1):
            span = set(range(i, i + n))
            if tuple(tokens[i : i + n]) == said and not span & taken:
                taken |= span
                found.append((i, Mention(" ".join(said), spellings[said])))
    return [m for _, m in sorted(found, key=lambda f: f[0])]
