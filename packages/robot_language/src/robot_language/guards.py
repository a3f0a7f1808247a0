"""Last checks on a reading before anything acts on it (issue 32): a place the person said not
to use is never driven to, proposed or offered as a choice; a round said a number of times is
repeated in order, and more rounds than allowed are asked about."""

from __future__ import annotations

import re
from dataclasses import replace

from robot_language import saying
from robot_language.composites import MAX_ROUNDS
from robot_language.places import PlaceIndex
from robot_language.reading import Action, Question, Reading

_EACH = re.compile(r"\s*(?:,|\bor\b|\band\b|\bnor\b)\s*")


def names_a_place(places: PlaceIndex | None, phrase: str) -> bool:
    """Whether ``phrase`` names (or nearly names) a place on the live map."""
    return places is not None and bool(places.resolve(phrase).names)


def negated_places(phrases: list[str], places: PlaceIndex | None) -> set[str]:
    """The map ids the negated phrases could mean (every candidate: never guess which)."""
    if places is None:
        return set()
    said = [p for phrase in phrases for p in _EACH.split(phrase) if p.strip()]
    return {name for phrase in said for name in places.resolve(phrase).names}


def respect(reading: Reading, negated: set[str], places: PlaceIndex | None) -> Reading:
    """``reading`` with no action, question or choice that uses a negated place."""
    if not negated:
        return reading
    if reading.kind == "act" and any(_uses(a, negated) for a in reading.actions):
        return _refused(negated, places)
    question = reading.question
    if reading.kind != "ask" or question is None:
        return reading
    options = [o for o in question.options if o not in negated]
    actions = question.actions
    if question.mode == "choose" and options != question.options:
        if not options:
            return _refused(negated, places)
        if len(options) == 1:
            done = question.complete(options[0])
            if any(_uses(a, negated) for a in done):
                return _refused(negated, places)
            text = saying.confirm(done, places)
            return replace(reading, question=Question(text, "confirm", done))
        question = replace(question, options=options)
    kept = [a for i, a in enumerate(actions) if not (_uses(a, negated) and
                                                     not _open_slot(question, i))]  # fmt: skip
    if len(kept) != len(actions):
        return _refused(negated, places)
    return replace(reading, question=question)


def repeated(reading: Reading, rounds: int, places: PlaceIndex | None) -> Reading:
    """The actions said ``rounds`` times, in order; more than MAX_ROUNDS is asked about."""
    if rounds <= 1 or reading.kind != "act" or not reading.actions:
        return reading
    if rounds <= MAX_ROUNDS:
        return replace(reading, actions=reading.actions * rounds)
    most = reading.actions * MAX_ROUNDS
    text = (
        f"That's {rounds} rounds; I do at most {MAX_ROUNDS} in one go. Do you want me to "
        f"{saying.plan(reading.actions, places)}, {MAX_ROUNDS} times? (yes or no)"
    )
    return Reading("ask", question=Question(text, "confirm", most), intent=reading.intent)


def _uses(action: Action, negated: set[str]) -> bool:
    return action.place in negated or action.to in negated


def _open_slot(question: Question, index: int) -> bool:
    """Action ``index`` waits for the answer to fill its place (it isn't chosen yet)."""
    return (
        question.mode in ("choose", "fill")
        and question.index == index
        and (question.slot in ("place", "to"))
    )


def _refused(negated: set[str], places: PlaceIndex | None) -> Reading:
    said = " or ".join(sorted(saying.place_of(n, places) for n in negated))
    return Reading(
        "refuse",
        text=f"You told me not to go to {said}, so I won't. Tell me where to go instead.",
        intent="negated",
    )
