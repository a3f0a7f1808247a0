"""Places from the live ``navigation.list_locations`` answer: names, aliases and descriptions,
resolved from the words people use ("Alice's desk", "the post room", "your charger")."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field, replace

from robot_language import fuzzy
from robot_language.config_file import word_lists
from robot_language.normalise import possessors

# where a description's head (the place's own name) ends: "Kitchen with the ...", "Alice's desk
# in the ...", "Reception desk, usually ..."
_WORDS = word_lists("words", "place_stop", "rooms", "not_in_place_names")
_STOP = _WORDS["place_stop"]
_HEAD_END = re.compile(
    r"[,;.:()]| - | — | (?:in|with|next|near|by|on|at|for|where|which|that|leads|usually|of)\b"
)


def located(spoken: str) -> str:
    """``spoken`` (a place as a sentence says it) with its preposition: "in the kitchen", "in
    the meeting room Harbour", "at reception", "at Alice's desk". The head noun decides: the
    last word that is not a name after it ("Harbour"), a letter or a number ("corridor b")."""
    for word in reversed(re.findall(r"[\w'’-]+", spoken)):
        low = word.lower()
        if low in _WORDS["rooms"] or low.endswith("room"):
            return f"in {spoken}"
        if len(word) > 1 and not word.isdigit() and not word[:1].isupper():
            break
    return f"at {spoken}"


def words(text: str) -> list[str]:
    return re.findall(r"[a-z0-9]+", text.lower().replace("'s", " ").replace("’s", " "))


def stem(word: str) -> str:
    for suffix in ("ing", "ers", "er", "es", "ed", "s", "e"):
        if word.endswith(suffix) and len(word) - len(suffix) >= 4:
            return word[: -len(suffix)]
    return word


def key(text: str) -> str:
    return " ".join(words(text))


@dataclass(frozen=True)
class Place:
    name: str
    aliases: tuple[str, ...] = ()
    description: str = ""
    # where it is on the map and how far from the robot, as list_locations gave them
    x: float | None = None
    y: float | None = None
    distance_m: float | None = None
    eta_s: float | None = None

    def spellings(self) -> list[str]:
        return [key(self.name), *[key(a) for a in self.aliases]]

    def vocabulary(self) -> set[str]:
        """Every word of its name, aliases and description (for a near spelling)."""
        return set(words(" ".join([self.name, *self.aliases, self.description])))

    def bag(self) -> set[str]:
        return {stem(w) for w in self.vocabulary()}

    def spoken(self) -> str:
        """How a sentence names it: the description's head when it names this place ("Alice's
        desk", "the charging dock"), else the id with spaces ("the desk bob")."""
        description = self.description.replace('"', "").replace("_", " ")  # never an id
        head = _HEAD_END.split(description, maxsplit=1)[0].strip()
        ours = {stem(w) for w in words(" ".join([self.name, *self.aliases]))}
        said = words(head)
        if not head or len(said) > 4 or not ours & {stem(w) for w in said}:
            return f"the {self.name.replace('_', ' ')}"
        first = head.split(" ", 1)[0]
        if first.endswith(("'s", "’s")):  # a person's place: "Alice's desk", no article
            return head
        return f"the {head[:1].lower()}{head[1:]}"

    def label(self) -> str:
        """How a person names it: "reception", "desk alice (Alice's desk …)"."""
        spoken = self.name.replace("_", " ")
        return f"{spoken} ({self.description.rstrip('.')})" if self.description else spoken


@dataclass(frozen=True)
class PlaceMatch:
    """``names`` best first; ``sure`` when exactly one place fits every word; ``near`` when
    the words were only close to the place's (a typo: "kichen"), so an unsure one is asked as
    "Did you mean the kitchen?"."""

    phrase: str
    names: list[str] = field(default_factory=list)
    sure: bool = False
    near: bool = False


@dataclass
class PlaceIndex:
    places: list[Place] = field(default_factory=list)
    place_words: dict[str, list[str]] = field(default_factory=dict)
    # places the person ruled out ("not Alice's"): never a candidate among others
    excluded: frozenset[str] = frozenset()

    @classmethod
    def from_result(cls, text: str, place_words: dict[str, list[str]] | None = None) -> PlaceIndex:
        """From ``list_locations``' answer; anything unreadable gives an empty index."""
        try:
            data = json.loads(text)
        except ValueError:
            data = None
        items = data.get("locations", []) if isinstance(data, dict) else []
        items = items if isinstance(items, list) else []
        places = [
            Place(
                item["name"],
                tuple(a for a in item.get("aliases") or [] if isinstance(a, str)),
                str(item.get("description") or ""),
                *(_number(item.get(k)) for k in ("x", "y", "distance_m", "est_duration_s")),
            )
            for item in items
            if isinstance(item, dict) and isinstance(item.get("name"), str)
        ]
        return cls(places, dict(place_words or {}))

    def known(self) -> list[str]:
        return [p.name for p in self.places]

    def spoken(self, name: str) -> str:
        """``name`` (a map id) as a sentence says it; an unknown id with spaces."""
        place = self.get(name)
        return place.spoken() if place else f"the {name.replace('_', ' ')}"

    def get(self, name: str) -> Place | None:
        return next((p for p in self.places if p.name == name), None)

    def excluding(self, names: set[str]) -> PlaceIndex:
        """This index with ``names`` ruled out as candidates (a place named alone stays, so a
        request for it is refused as negated, not read as an unknown place)."""
        return replace(self, excluded=frozenset(names))

    def resolve(self, phrase: str, among: list[str] | None = None) -> PlaceMatch:
        """Exact name or alias; else a name or alias inside the phrase (longest wins); else
        the places whose words (name, aliases, description) hold every word of the phrase.
        Places ruled out are dropped from several candidates; one left is only a guess."""
        match = self._resolve(phrase, among)
        kept = [n for n in match.names if n not in self.excluded]
        if not self.excluded or len(match.names) < 2 or kept == match.names or not kept:
            return match
        return PlaceMatch(phrase, kept, False, near=True)

    def _resolve(self, phrase: str, among: list[str] | None = None) -> PlaceMatch:
        places = [p for p in self.places if among is None or p.name in among]
        wanted = key(phrase)
        exact = [p.name for p in places if wanted in p.spellings()]
        if exact:
            return PlaceMatch(phrase, exact[:1], True)
        inside = [
            (len(s), p.name)
            for p in places
            for s in p.spellings()
            if s and re.search(rf"(?:^| ){re.escape(s)}(?: |$)", wanted)
        ]
        if inside:
            longest = max(n for n, _ in inside)
            names = list(dict.fromkeys(name for n, name in inside if n == longest))
            return PlaceMatch(phrase, names, len(names) == 1)
        content = [w for w in words(phrase) if w not in _STOP]
        if not content:
            return PlaceMatch(phrase)
        fits = self._fits(content, places)
        if fits:
            return PlaceMatch(phrase, fits, len(fits) == 1)
        return self._near(phrase, content, places)

    def _fits(self, content: list[str], places: list[Place]) -> list[str]:
        """The places whose words hold every word of ``content`` (or a site's word for it)."""
        looks = [[stem(w), *self.place_words.get(w, [])] for w in content]
        return [p.name for p in places if all(any(x in p.bag() for x in alts) for alts in looks)]

    def _near(self, phrase: str, content: list[str], places: list[Place]) -> PlaceMatch:
        """Nothing fits the words as said: a place whose name, alias or own name in its
        description is spelled close to the phrase ("mial room"), else the places that fit once
        each unknown word is read as the nearest word of the map ("kichen" → kitchen). Sure
        only when one place is clearly nearest; a word near nothing matches nothing."""
        wanted = " ".join(content)
        scored: dict[str, float] = {}
        for place in places:
            found = fuzzy.nearest(wanted, [*place.spellings(), key(place.spoken())])
            if found:
                scored[place.name] = found[0].score
        if scored:
            ranked = sorted(scored.items(), key=lambda kv: kv[1], reverse=True)
            best = [fuzzy.Near(n, s) for n, s in ranked]
            names = [n for n, s in ranked if s >= ranked[0][1] - fuzzy.MARGIN]
            return PlaceMatch(phrase, names, fuzzy.clear(best), near=True)
        vocabulary = set().union(*(p.vocabulary() for p in places)) if places else set()
        known = set(self.place_words) | vocabulary
        read: list[str] = []
        sure = True
        for word in content:
            if word in known or any(stem(word) in p.bag() for p in places):
                read.append(word)
                continue
            found = fuzzy.nearest(word, vocabulary)
            if not found:
                return PlaceMatch(phrase)
            sure = sure and fuzzy.clear(found)
            read.append(found[0].text)
        fits = self._fits(read, places)
        return PlaceMatch(phrase, fits, sure and len(fits) == 1, near=bool(fits))

    def owners(self) -> set[str]:
        """Whose places the map has ("Alice's desk" → alice): "alices desk" is Alice's."""
        return possessors(p.description for p in self.places)

    def only_place(self, phrase: str) -> bool:
        """``phrase`` names one place and says nothing else ("the post room", "kitchen")."""
        match = self.resolve(phrase)
        if not match.sure:
            return False
        if match.near:  # "the reciption": a place said a little wrong, and nothing else
            return len([w for w in words(phrase) if w not in _STOP]) <= 3
        place = self.get(match.names[0])
        assert place is not None
        spelled = set(" ".join(place.spellings()).split())
        rest = [w for w in words(phrase) if w not in _STOP and w not in spelled]
        return len(rest) <= 2 and bool(self._fits(rest, [place]))


def _number(value: object) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


_LONGEST_PLACE_NAME = 6  # words, articles not counted


def could_name_a_place(phrase: str) -> bool:
    """Whether ``phrase`` (not found on the map) could still be the name of a place."""
    said = [w for w in words(phrase) if w not in ("the", "a", "an")]
    return 0 < len(said) <= _LONGEST_PLACE_NAME and not _WORDS["not_in_place_names"] & set(said)
