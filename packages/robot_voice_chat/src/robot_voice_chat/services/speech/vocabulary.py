"""What the robot can be told, as a JSGF grammar for the on-board recognizer.

Built from the live state: places (names, aliases and the description's own name, from
``navigation.list_locations``), object labels (site configuration plus every label episodic
memory has a sighting of, ``episodic.known_labels``), and the understanding layer's intents
(``intents.yaml``: each intent's verbs before a place or an object, its example sentences as
they are). The grammar covers what the
typed path understands: sequences ("X and then Y"), fetch / bring / put, find / look / what do
you see, where questions, stop / continue / abort / never mind, negation and correction ("don't
go to X", "X no wait Y"), and yes/no answers.

A sentence outside the grammar cannot come out of the recognizer; it is squeezed into the
nearest sentence inside it, which is why the recognizer scores each hypothesis
(``onboard.py``) and :func:`kind_of` tells which hypotheses would move the robot.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from robot_language.intents import IntentFile, load_intents
from robot_voice_chat.services.speech.base import HeardKind

_WORD = re.compile(r"[a-z][a-z']*")
# where a description's own name ends ("Alice's desk in the open-plan office")
_HEAD_END = re.compile(
    r"[,;.:()\"]| - | (?:in|with|next|near|by|on|at|for|where|which|that|leads|usually|of)\b"
)
_ARTICLES = ("the", "a", "an", "my", "your", "our", "some")

#: object labels any site has (a site adds its own, and the brain adds what it heard of)
DEFAULT_OBJECTS = (
    "package", "parcel", "box", "mug", "cup", "bottle", "scissors", "keys", "stapler", "laptop",
    "person", "letter", "book", "phone", "bag", "chair",
)  # fmt: skip
COLOURS = ("red", "green", "blue", "yellow", "black", "white", "orange", "brown")

# the intents' verbs the grammar listens for (intents.yaml has many more ways to say each;
# the typed path reads them all)
SPOKEN_VERBS = frozenset({
    "go to", "go back to", "drive to", "head to", "navigate to", "return to", "move to",
    "find", "look for", "search for", "locate",
    "fetch", "bring me", "get", "pick up", "grab", "collect", "get me",
    "bring", "take", "deliver", "carry",
    "watch for", "tell me when you see", "let me know when you see", "keep an eye out for",
})  # fmt: skip
# the parts of the typed path that are not intents (rules/commands.py, negation.py, follow_up)
OPENERS = ("please", "hey robot", "robot", "okay", "ok", "so", "can you", "could you", "hey")
CLOSERS = ("please", "thanks", "thank you", "now")
JOINERS = ("and", "then", "and then", "after that")
NEGATIONS = ("don't", "do not", "never")
CORRECTIONS = ("no wait", "no", "actually", "sorry i meant", "i mean", "make that", "wait")
YES = ("yes", "yeah", "yep", "sure", "correct", "right", "yes please", "that's right")
NO = ("no", "nope", "no thanks", "never mind", "cancel", "forget it")
CONTROL = (
    "stop", "halt", "freeze", "stop right now", "abort", "abort the mission", "cancel the mission",
    "continue", "carry on", "keep going", "go on", "resume", "resume the mission",
)  # fmt: skip
# said alone, or first, a stop is heard without the wake phrase (spec 002 §9)
STOPS = frozenset({"stop", "halt", "freeze", "stop right now", "abort", "abort the mission"})
# what carries a paused mission on (CONTROL's second half): it moves the robot
RESUMES = frozenset({"continue", "carry on", "keep going", "go on", "resume"})
ORDINALS = ("the first one", "the second one", "the third one", "the first", "the second")
ARM = {
    # the arm's own verbs (understanding/README.md §4): pick here, put at a place, release
    "pick": ("pick up", "grab"),
    "put": ("put it", "place it", "set it", "leave it", "put it down", "set it down"),
    "release": ("hand it over", "drop it", "give it to me", "let go"),
}
# find verbs that ask a question (answered from memory first, understanding/README.md)
QUESTION_VERBS = frozenset({"where's", "where is", "where are", "is there", "are there", "is",
                            "do you see", "can you see"})  # fmt: skip


def words_of(text: str) -> list[str]:
    return _WORD.findall(text.lower().replace("’", "'"))


def addressed(text: str, wake: str) -> tuple[str, bool]:
    """``text`` without a leading wake phrase ("hey robbie, go to the kitchen" → "go to the
    kitchen", True); (``text``, False) when it does not start with it."""
    said, name = words_of(text), words_of(wake)
    for start in (0, 1):  # "robbie …", or "hey robbie …" / "ok robbie …"
        if name and said[start : start + len(name)] == name and (start == 0 or said[0] in _CALLS):
            return " ".join(said[start + len(name) :]), True
    return text, False


def is_stop(text: str) -> bool:
    """A stop word alone or first ("stop", "halt right there"): always listened for."""
    said = words_of(text)
    return " ".join(said) in STOPS or (bool(said) and said[0] in {"stop", "halt", "freeze"})


_CALLS = frozenset({"hey", "ok", "okay", "hi", "hello"})


def spoken_names(place: dict[str, object]) -> list[str]:
    """How people name one ``list_locations`` entry: its id with spaces, each alias, and the
    description's own name ("Alice's desk", "East corridor", the quoted "Harbour")."""
    names: list[str] = []
    for raw in [place.get("name"), *(place.get("aliases") or [])]:  # type: ignore[misc]
        if isinstance(raw, str):
            names.append(raw.replace("_", " ").replace("-", " "))
    description = place.get("description")
    if isinstance(description, str) and description:
        names += re.findall(r'"([^"]+)"', description)
        head = _HEAD_END.split(description, maxsplit=1)[0]
        if 0 < len(head.split()) <= 4:
            names.append(head)
    spoken = [" ".join(words_of(n)) for n in names]
    return list(dict.fromkeys(s for s in spoken if s))


def places_from_listing(text: str) -> list[list[str]]:
    """``list_locations``' JSON answer → the spoken names of each place (unreadable → [])."""
    try:
        data = json.loads(text)
    except ValueError:
        return []
    items = data.get("locations") if isinstance(data, dict) else None
    return [spoken_names(item) for item in items or [] if isinstance(item, dict)]


KNOWN_LABELS = "episodic.known_labels"  # the tool that lists every label the robot has seen


def labels_from_listing(text: str) -> list[str] | None:
    """``episodic.known_labels``' JSON answer → the labels as spoken ("coffee_mug" → "coffee
    mug"); None when unreadable."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    labels = data.get("labels") if isinstance(data, dict) else None
    if not isinstance(labels, list):
        return None
    spoken = (
        " ".join(words_of(label.replace("_", " "))) for label in labels if isinstance(label, str)
    )
    return list(dict.fromkeys(s for s in spoken if s))


@dataclass(frozen=True)
class Vocabulary:
    """The live words: places (each a list of spoken names), objects, and intents."""

    places: tuple[tuple[str, ...], ...] = ()
    objects: tuple[str, ...] = DEFAULT_OBJECTS
    intents: IntentFile = field(default_factory=load_intents, compare=False, hash=False)
    wake: str = ""  # the site's wake phrase ("robbie"): heard as an opener

    @classmethod
    def build(
        cls,
        places: Iterable[Iterable[str]],
        objects: Iterable[str] = DEFAULT_OBJECTS,
        intents: IntentFile | None = None,
        wake: str = "",
    ) -> Vocabulary:
        return cls(
            tuple(tuple(p) for p in places if p),
            tuple(dict.fromkeys(" ".join(words_of(o)) for o in objects if words_of(o))),
            intents if intents is not None else load_intents(),
            " ".join(words_of(wake)),
        )

    def with_live(
        self,
        places: Iterable[Iterable[str]],
        configured: Iterable[str],
        heard_of: Iterable[str],
        wake: str,
    ) -> Vocabulary:
        """These intents with the live places, the configured object labels and those heard of
        since (episodic memory's ``known_labels``), and the site's wake phrase."""
        return Vocabulary.build(places, [*configured, *heard_of], self.intents, wake)

    def digest(self) -> str:
        """Changes when anything the grammar is made of changes (the grammar is rebuilt)."""
        intents = self.intents.model_dump_json()
        blob = json.dumps([self.places, self.objects, intents, self.wake], sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def place_phrases(self) -> list[str]:
        return sorted({name for place in self.places for name in place})

    def intent_verbs(self, name: str, spoken: bool = False) -> list[str]:
        """The intent's verbs; ``spoken``: only those people say to a robot most (each extra
        verb is one more way for a grammar recognizer to mishear "go to" as "walk to")."""
        intent = self.intents.intents.get(name)
        verbs = [" ".join(words_of(v)) for v in intent.verbs] if intent else []
        return [v for v in verbs if v in SPOKEN_VERBS] if spoken else verbs

    def examples(self) -> list[str]:
        """Every example sentence of every intent (out-of-scope ones too: "what's the weather
        like" is heard as it is and refused by the understanding layer, not squeezed into a
        command)."""
        said = [
            " ".join(words_of(e))
            for i in self.intents.intents.values()
            if i.kind != "action"  # the commands are built from the verbs, places and objects
            for e in i.examples
        ]
        return sorted({s for s in said if s})


def _alt(items: Iterable[str]) -> str:
    unique = sorted({i for i in items if i})
    return "(" + " | ".join(unique) + ")" if unique else VOID


def rules(vocabulary: Vocabulary, known: Callable[[str], bool] = lambda _w: True) -> dict[str, str]:
    """The grammar's rules (name → JSGF expansion); ``utterance`` is the public one. Phrases
    with a word the dictionary does not know (``known``) are left out: the recognizer cannot
    hear a word it cannot pronounce."""

    def ok(phrase: str) -> bool:
        return all(known(w) for w in phrase.split())

    def alt(items: Iterable[str]) -> str:
        return _alt(i for i in items if ok(i))

    places = [p for p in vocabulary.place_phrases() if ok(p)]
    objects = [o for o in vocabulary.objects if ok(o)]
    goto = vocabulary.intent_verbs("goto", spoken=True)
    find = vocabulary.intent_verbs("find", spoken=True)
    fetch = vocabulary.intent_verbs("fetch", spoken=True)
    deliver = vocabulary.intent_verbs("deliver", spoken=True)
    watch = vocabulary.intent_verbs("watch", spoken=True)
    return {
        "utterance": "[<opener>] <request> [<closer>]",
        "opener": alt([*OPENERS, vocabulary.wake]),
        "closer": alt(CLOSERS),
        "request": "<commands> | <negated> | <corrected> | <answer> | <control> | <phrase>",
        "commands": "<command> [<joiner> <command>]",
        "joiner": alt(JOINERS),
        "command": "<goto> | <find> | <fetch> | <deliver> | <watch> | <arm>",
        "place": f"[the] {alt(places)}",
        "object": f"[{alt(_ARTICLES)}] [{alt(COLOURS)}] {alt(objects)}",
        "goto": f"{alt(goto)} <place> | {alt(['go', 'drive', 'head', 'come'])} "
        f"{alt(['home', 'back home', 'back to base', 'charge yourself'])}",
        "find": f"{alt(find)} <object> [{alt(['in', 'at', 'on', 'near'])} <place>]",
        "fetch": f"{alt(fetch)} <object> [{alt(['from', 'at', 'in', 'on'])} <place>] "
        "[<joiner> <deliver>]",
        "deliver": f"{alt(deliver)} {alt(['it', 'them', 'that'])} "
        f"{alt(['to', 'over to', 'off at'])} <place> | (bring | take) it to me",
        "watch": f"{alt(watch)} <object>",
        "arm": f"{alt(ARM['pick'])} <object> | {alt(ARM['put'])} "
        f"[{alt(['on', 'at', 'in', 'down at'])} <place>] | {alt(ARM['release'])}",
        "negated": f"{alt(NEGATIONS)} <goto> [[but] <goto>] | not <place> [<place>]",
        "corrected": f"<goto> {alt(CORRECTIONS)} (<place> | <goto>) "
        f"| <find> {alt(CORRECTIONS)} <object>",
        "answer": f"{alt([*YES, *NO, *ORDINALS])} | <place>",
        "control": alt(CONTROL),
        "phrase": alt(vocabulary.examples()),
    }


def jsgf(grammar: dict[str, str]) -> str:
    """The rules as a JSGF document (``utterance`` public)."""
    lines = ["#JSGF V1.0;", "grammar robot;"]
    for name, expansion in grammar.items():
        public = "public " if name == "utterance" else ""
        lines.append(f"{public}<{name}> = {expansion};")
    return "\n".join(lines) + "\n"


VOID = "<VOID>"
_SYNTAX = {"(": "(?:", "[": "(?:", ")": ")", "]": ")?", "|": "|"}
_TOKEN = re.compile(r"<[a-z_]+>|[()\[\]|]|[^\s()\[\]|<>]+")


def matcher(grammar: dict[str, str]) -> re.Pattern[str]:
    """A regular expression that matches exactly the sentences of the grammar (words joined by
    one space, a trailing space): the recognizer returns its best *partial* path when the
    audio never reached the end of a sentence ("find the scissors in the"), which is then not a
    sentence it heard."""
    done: dict[str, str] = {}

    def expand(name: str) -> str:
        if name not in done:
            out = []
            for token in _TOKEN.findall(grammar[name]):
                if token.startswith("<"):
                    out.append("(?!)" if token == VOID else f"(?:{expand(token[1:-1])})")
                else:
                    out.append(_SYNTAX.get(token, re.escape(token) + " "))
            done[name] = "".join(out)
        return done[name]

    return re.compile(f"(?:{expand('utterance')})")


def is_sentence(text: str, pattern: re.Pattern[str]) -> bool:
    said = " ".join(words_of(text))
    return bool(said) and pattern.fullmatch(said + " ") is not None


def _names_a_place(said: str, vocabulary: Vocabulary) -> bool:
    padded = f" {said} "
    return any(f" {place} " in padded for place in vocabulary.place_phrases())


def kind_of(text: str, vocabulary: Vocabulary) -> HeardKind:
    """What a hypothesis asks for, read from the grammar's own phrases: ``stop`` (a stop
    word), ``answer`` (yes / no / an ordinal), ``motion`` (a clause that starts with a verb
    that moves the robot, its arm or its camera, or a place named without a verb: the typed
    path reads "the kitchen" as "go there"), ``other`` (questions, small talk, a negation
    alone: "don't go to the kitchen" moves nothing)."""
    said = addressed(" ".join(words_of(text)), vocabulary.wake)[0]
    if said in STOPS:
        return "stop"
    first = said.split()
    if " ".join(first[:1]) in RESUMES or " ".join(first[:2]) in RESUMES:
        return "motion"  # a paused mission drives on: read back when unsure, like a drive
    if said in {*YES, *NO, *ORDINALS}:
        return "answer"
    verbs = {
        *vocabulary.intent_verbs("goto"),
        *vocabulary.intent_verbs("find"),
        *vocabulary.intent_verbs("fetch"),
        *vocabulary.intent_verbs("deliver"),
        *vocabulary.intent_verbs("watch"),
        *ARM["pick"],
        *ARM["put"],
        *ARM["release"],
        "look around",
        "what do you see",
    } - QUESTION_VERBS
    tokens = said.split()
    before = {*JOINERS, *CORRECTIONS, *NEGATIONS, *OPENERS, "but"}
    starts = [
        i
        for i in range(len(tokens))
        if (i == 0 or tokens[i - 1] in before or " ".join(tokens[max(0, i - 2) : i]) in before)
        and any(tokens[i : i + len(v.split())] == v.split() for v in verbs if v)
    ]
    if not any(said.startswith(f"{n} ") for n in NEGATIONS):
        # a place named without a verb ("the east corridor", "please the meeting room") is
        # read by the typed path as "go there": a motion, read back when unsure
        return "motion" if starts or _names_a_place(said, vocabulary) else "other"
    # "don't go to X[, go to Y]": the negated command moves nothing, a second one does
    anywhere = [
        i
        for i in range(len(tokens))
        if any(tokens[i : i + len(v.split())] == v.split() for v in verbs if v)
    ]
    return "motion" if anywhere and anywhere[-1] > anywhere[0] + 1 else "other"
