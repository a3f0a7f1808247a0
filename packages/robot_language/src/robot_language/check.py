"""The CHECK stage (issue 38, "nothing said is dropped"): the last look at a reading the robot
would act on. Every known place and object the sentence names is used by the reading or ruled
out; an object is one thing (not a place, a choice, a cut-off phrase); a place is on the map; a
sentence that stops at "... to" is not finished; a thing to leave alone is never handled; a
time, a condition or "not now" it cannot honour is said back. When the check fails the robot
asks one question saying what it understood and what it did not follow, or says what it will
not do. It never narrows the request on a guess."""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass, replace

from robot_language import saying
from robot_language.config_file import patterns
from robot_language.mentions import object_mentions, place_mentions
from robot_language.places import PlaceIndex, words
from robot_language.reading import Action, Question, Reading
from robot_language.saying import CUT_OFF

_HANDLING = ("pick", "put", "release", "fetch")
_OFFER = "Do you want me to"
_FIRST = "I can't check that before I start."
_CANNOT = {"later": "I can't do things at a later time yet.", "exception": _FIRST,
           "condition": _FIRST, "route": "I can't choose my way around a place yet."}  # fmt: skip
_Q = patterns("qualifiers", "not_now", "choice", "many", "back", "slot_in_thing", "hands_off",
              "wh_question", *_CANNOT)  # fmt: skip
_MAX_PLACE_WORDS = 4  # a place said in more words is a piece of sentence, not a name


@dataclass(frozen=True)
class _Found:
    """What the check found wrong with a reading, said in the robot's words."""

    why: str
    keep: list[Action]  # the sound part that may be offered as it is (yes / no)
    fill_to: int | None = None  # a fetch whose destination was cut off: asked for


def check(
    text: str,
    reading: Reading,
    places: PlaceIndex | None,
    ruled_out: Collection[str] = (),
    objects: Collection[str] = (),
) -> Reading:
    """``reading`` when nothing ``text`` (normalised) says is dropped or garbled; else one
    question or a refusal. Only readings that act are checked."""
    if reading.kind == "ask":
        return _said_back_whole(text, reading, places, ruled_out, objects)
    if reading.kind != "act" or not reading.actions:
        return reading
    found = (
        _hands_off(text, reading.actions, places)
        or _unsound(reading.actions, places)
        or _cut_off(text, reading.actions, places)
        or _dropped(text, reading.actions, places, ruled_out, objects)
        or _qualified(text, reading.actions, places)
    )
    if found is None:
        return reading
    return _reply(found, reading, places)


def _said_back_whole(
    text: str,
    reading: Reading,
    places: PlaceIndex | None,
    ruled_out: Collection[str],
    objects: Collection[str],
) -> Reading:
    """A yes/no question that says back only part of the sentence says what it left out (a
    yes then does only that part, knowingly)."""
    question = reading.question
    if question is None or question.mode != "confirm" or not question.text.startswith(_OFFER):
        return reading
    hands_off = _hands_off(text, question.actions, places)
    if hands_off is not None:  # never offer to handle what is to be left alone
        return _reply(hands_off, reading, places)
    found = _dropped(text, question.actions, places, ruled_out, objects)
    if found is None:
        return reading
    text = f"{found.why} {_OFFER} just {question.text.removeprefix(_OFFER).lstrip()}"
    return replace(reading, question=replace(question, text=text))


def check_answer(reading: Reading, places: PlaceIndex | None) -> Reading:
    """The reading an answer to a question completed, its slots checked again (the answer "the
    kitchen" to "Where should I get the mug to Bob's desk from?": no thing "mug to Bob's desk")."""
    if reading.kind != "act" or not reading.actions:
        return reading
    found = _unsound(reading.actions, places)
    return reading if found is None else _reply(found, reading, places)


def _hands_off(text: str, actions: list[Action], places: PlaceIndex | None) -> _Found | None:
    """A thing said to be left alone is handled by the reading."""
    match = _Q["hands_off"].search(text)
    if match is None:
        return None
    said = (match["left"] or match["touch"] or "").strip()
    left = set(words(said)) - {"the", "a", "an", "my", "it"}
    handled = [
        a for a in actions if a.kind in _HANDLING and (not a.obj or left & set(words(a.obj)))
    ]
    if not left or not handled:
        return None
    thing = saying.thing(said or handled[0].obj)
    keep = [a for a in actions if a not in handled]
    return _Found(f"You said to leave {thing} alone, so I won't move it.", keep)


def _qualified(text: str, actions: list[Action], places: PlaceIndex | None) -> _Found | None:
    """The sentence says when, unless, or which of several — what the robot cannot honour: it
    does things now, tests no condition first and carries one thing it was told of."""
    if _Q["not_now"].search(text):
        return _Found(f"OK, not now. Tell me when to {saying.plan(actions, places)}.", [])
    moving_only = all(a.kind in ("goto", "find") for a in actions)
    for name, why in _CANNOT.items():
        if (match := _Q[name].search(text)) and (name != "condition" or moving_only):
            return _Found(f"You said {match[0].strip(' ,')!r}, and {why}", actions)
    for obj in (a.obj for a in actions if a.kind in _HANDLING and a.obj):
        if _Q["back"].search(obj):
            return _Found("I won't guess where to put it back: tell me the place.", [])
        if _Q["choice"].search(obj) or _Q["many"].search(obj):
            why = f"I carry one thing at a time and won't choose for you: you said {obj!r}."
            return _Found(f"{why} Tell me the one thing to take.", [])
    return None


def _unsound(actions: list[Action], places: PlaceIndex | None) -> _Found | None:
    """An object that holds a place or stops at a preposition; a place that is a sentence."""
    for action in actions:
        obj = action.obj or ""
        inside = place_mentions(obj, places)
        if inside:
            where = saying.place_of(inside[0].name, places)
            return _Found(
                f"I won't guess: I heard {obj!r} as one thing, but {where} is a place. Please "
                "tell me again what to do with the thing and with the place.",
                [],
            )
        if obj and obj.split()[-1] in CUT_OFF:
            return _Found(f"I didn't catch the end of {obj!r}.", [])
        if action.kind in _HANDLING and _Q["slot_in_thing"].search(obj):
            return _Found(f"I won't guess: I heard {obj!r} as one thing. Who is it for?", [])
        for slot in (action.place, action.to):
            if slot and not _a_place(slot, places):
                return _Found(f"I don't know {slot!r} as a place.", [])
    return None


def _a_place(slot: str, places: PlaceIndex | None) -> bool:
    if places is not None and places.places:
        return places.get(slot) is not None
    return len(slot.split()) <= _MAX_PLACE_WORDS and slot.split()[-1] not in CUT_OFF


def _cut_off(text: str, actions: list[Action], places: PlaceIndex | None) -> _Found | None:
    """The sentence stops at a word that needs more after it."""
    said = re.findall(r"[\w']+", text)
    if not said or said[-1] not in CUT_OFF or _Q["wh_question"].match(text):
        return None
    last = actions[-1]
    if said[-1] == "to" and last.kind == "fetch" and last.to is None:
        return _Found(f"You stopped after {said[-1]!r}.", actions, fill_to=len(actions) - 1)
    return _Found(f"You stopped after {said[-1]!r}, so I may have missed the rest.", actions)


def _dropped(
    text: str,
    actions: list[Action],
    places: PlaceIndex | None,
    ruled_out: Collection[str],
    objects: Collection[str],
) -> _Found | None:
    """Known places and objects the sentence names that the reading does not use."""
    used = {p for a in actions for p in (a.place, a.to) if p} | set(ruled_out)
    left = [m for m in place_mentions(text, places) if m.name not in used]
    said_objects = set(words(" ".join(a.obj or "" for a in actions)))
    left += [m for m in object_mentions(text, objects) if not set(m.said.split()) <= said_objects]
    if not left:
        return None
    said = [saying.thing(m.name) if m.label else saying.place_of(m.name, places) for m in left]
    names = list(dict.fromkeys(said))
    listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return _Found(f"You also said {listed}, and I didn't follow what to do with that.", actions)


def _reply(found: _Found, reading: Reading, places: PlaceIndex | None) -> Reading:
    """One question naming what was understood and what was not; or what won't be done."""
    if found.fill_to is not None:
        last = found.keep[found.fill_to]
        text = f"{found.why} Where should I bring {saying.thing(last.obj)}?"
        question = Question(text, "fill", found.keep, index=found.fill_to, slot="to")
        return Reading("ask", question=question, intent=reading.intent, stage=reading.stage)
    if not found.keep:
        return Reading("refuse", text=found.why, intent="unchecked", stage=reading.stage)
    plan = saying.plan(found.keep, places)
    text = f"{found.why} Do you want me to just {plan}? (yes or no)"
    question = Question(text, "confirm", found.keep)
    return Reading("ask", question=question, intent=reading.intent, stage=reading.stage)
