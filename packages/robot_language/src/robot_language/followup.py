"""The answer to a question the understanding layer asked: a yes, a choice, the missing slot,
"never mind", or a correction ("no, the mailroom") of the place it asked about."""

from __future__ import annotations

import re

from robot_language import clauses as cl
from robot_language.config_file import patterns
from robot_language.normalise import normalise
from robot_language.places import PlaceIndex
from robot_language.reading import Question, Reading

_P = patterns("followup", "cancel", "yes", "no_but")
_ORDINALS = {"first": 0, "former": 0, "second": 1, "latter": -1, "third": 2, "last": -1}


def follow_up(question: Question, answer: str, places: PlaceIndex | None) -> Reading | None:
    """The request completed by ``answer``; a cancel; or None (not an answer: read it as a new
    request)."""
    owners = places.owners() if places is not None else ()
    text = cl.tidy(normalise(answer, owners))
    corrected = _instead(question, text, places)
    if corrected is not None:
        return corrected
    if _P["cancel"].match(text):
        return Reading("cancel", text="OK, never mind: I won't do anything.", stage="answer")
    if question.mode == "confirm":
        return Reading("act", question.actions, stage="answer") if _P["yes"].match(text) else None
    if question.mode == "choose":
        picked = _ordinal(text, question.options)
        if picked is None and places is not None:
            match = places.resolve(cl.strip_article(text), among=question.options)
            picked = match.names[0] if match.sure else None
        if picked is None:
            return None
        return Reading("act", question.complete(picked), stage="answer")
    if question.slot == "obj":
        obj = cl.strip_article(text)
        return Reading("act", question.complete(obj), stage="answer") if obj else None
    if places is None:
        return Reading("act", question.complete(cl.strip_article(text)), stage="answer")
    match = places.resolve(cl.strip_article(re.sub(r"^(?:to|go to)\s+", "", text)))
    return Reading("act", question.complete(match.names[0]), stage="answer") if match.sure else None


def _instead(question: Question, text: str, places: PlaceIndex | None) -> Reading | None:
    """ "no, the mailroom" to a question about one drive: that drive, to the place said, when
    the place is sure (else None, and the answer is read as a cancel or a new request)."""
    said = _P["no_but"].match(text)
    if said is None or places is None or len(question.actions) != 1:
        return None
    action = question.actions[0]
    if action.kind != "goto":
        return None
    match = places.resolve(cl.strip_article(said["rest"]))
    if not match.sure or match.names[0] == action.place:
        return None
    redone = Question("", "fill", question.actions, index=0, slot="place")
    return Reading("act", redone.complete(match.names[0]), stage="answer")


def _ordinal(text: str, options: list[str]) -> str | None:
    for word, index in _ORDINALS.items():
        if re.search(rf"\b{word}\b", text) and -len(options) <= index < len(options):
            return options[index]
    return None
