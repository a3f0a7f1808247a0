"""Legs put together into one reading: the actions in order, a delivery joined to the fetch
before it, and whatever is unsure or unknown turned into one question or a refusal (never an
action on a guess). Pure: the understanding layer reads the legs, this composes them."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

from robot_language import saying
from robot_language.config_file import patterns
from robot_language.places import PlaceIndex, key
from robot_language.reading import Action, Question, Reading

Status = Literal["ok", "ambiguous", "unknown_place", "missing", "unclear", "bare", "deliver"]


_THEM = patterns("clauses", "them")["them"]


@dataclass
class Leg:
    """One part of the sentence as read: its action, how sure, and what is missing."""

    text: str
    status: Status = "ok"
    action: Action | None = None
    intent: str = ""
    score: float = 1.0
    sure: bool = True
    stage: Literal["grammar", "roles", "semantic"] = "grammar"
    slot: Literal["place", "obj", "to"] = "place"
    options: list[str] = field(default_factory=list)
    phrase: str = ""
    more: bool = False  # another object of the search before it ("... and a yellow package")
    near: bool = False  # the place was only spelled close to one on the map


def compose(text: str, legs: list[Leg], places: PlaceIndex | None) -> Reading:
    actions: list[Action] = []
    problems: list[tuple[int, Leg]] = []
    for leg in legs:
        previous = actions[-1] if actions else None
        if leg.status == "bare" and previous is not None and previous.kind != "goto":
            leg.status = "unclear"
        if leg.status == "deliver" or (
            leg.status != "ok" and leg.slot == "to" and leg.intent == "deliver"
        ):
            if previous is None or not _brought_on(previous):
                leg.status = "unclear"
                problems.append((len(actions), leg))
                continue
            assert leg.action is not None
            actions[-1] = replace(previous, kind="fetch", to=leg.action.to)
            if leg.status != "deliver":
                problems.append((len(actions) - 1, leg))
            continue
        if _fetch_there(leg, previous):
            leg.status = "ok"  # "from the kitchen, bring a plate to Q": get it there
        if leg.status in ("ok", "bare"):
            assert leg.action is not None
            if (
                leg.action.kind in ("find", "fetch")
                and leg.action.place is None
                and previous is not None
                and previous.kind == "goto"
            ):
                actions[-1] = replace(leg.action, place=previous.place)
            elif leg.more and previous is not None and leg.action.place is None:
                actions.append(replace(leg.action, place=previous.place))
            elif previous == leg.action and leg.action.kind in ("see", "goto"):
                pass  # "look around and tell me what you see": one look
            else:
                actions.append(leg.action)
            if not leg.sure:
                problems.append((len(actions) - 1, replace(leg, status="ok")))
            continue
        if leg.action is not None and leg.status in ("ambiguous", "missing"):
            actions.append(leg.action)
            problems.append((len(actions) - 1, leg))
        else:
            problems.append((len(actions), leg))
    score = min((leg.score for leg in legs), default=1.0)
    stage: Literal["grammar", "semantic"] = (
        "grammar" if all(leg.stage in ("grammar", "roles") for leg in legs) else "semantic"
    )
    intent = "+".join(leg.intent or "?" for leg in legs)
    reading = _problem(text, actions, problems, places) if problems else Reading("act", actions)
    return replace(reading, intent=intent, score=score, stage=stage)


def _problem(
    text: str,
    actions: list[Action],
    problems: list[tuple[int, Leg]],
    places: PlaceIndex | None,
) -> Reading:
    hard = [
        (i, leg) for i, leg in problems if leg.status in ("unclear", "unknown_place", "deliver")
    ]
    if len(problems) == 1:
        index, leg = problems[0]
        if leg.status == "ambiguous" and leg.near and len(leg.options) == 1:
            return Reading(
                "ask",
                question=saying.did_you_mean(actions, index, leg.slot, leg.options[0], places),
            )
        if leg.status == "ambiguous":
            return Reading("ask", question=_choose(actions, index, leg, places))
        if leg.status == "missing":
            return Reading("ask", question=_fill(actions, index, leg, places))
        if leg.status == "ok":  # understood, but not surely: say it back
            if not _sayable(actions, places):
                return unclear(text)  # never a fragment of the words said back
            question = Question(saying.confirm(actions, places), "confirm", actions)
            return Reading("ask", question=question)
    if hard and len(problems) == len(hard) and len(hard) == 1 and not actions:
        _, leg = hard[0]
        if leg.status == "unknown_place":
            return Reading("refuse", text=unknown_place(leg.phrase, places))
        return unclear(text)
    if not actions:
        return unclear(text)
    missed = "; ".join(
        unknown_place(leg.phrase, places)
        if leg.status == "unknown_place"
        else f"I didn't understand {leg.text!r}."
        for _, leg in hard
    )
    sure_actions = _known_only(actions, places)
    missing = [(i, leg) for i, leg in problems if leg.status == "missing"]
    if missing and not hard and _sayable(actions, places, placed=False):
        return Reading("ask", question=_fill(actions, *missing[0], places))  # never a hole
    if not _sayable(actions, places):
        return Reading("refuse", text=missed) if hard else unclear(text)
    if hard:
        if not sure_actions:
            return Reading("refuse", text=missed)
        partly = (
            f"I understood only part of that. {missed} "
            f"Do you want me to just {saying.plan(sure_actions, places)}? (yes or no)"
        )
        return Reading("ask", question=Question(partly, "confirm", sure_actions))
    return Reading("ask", question=Question(saying.confirm(actions, places), "confirm", actions))


def _choose(actions: list[Action], index: int, leg: Leg, places: PlaceIndex | None) -> Question:
    labels = [places.spoken(n) if places else n.replace("_", " ") for n in leg.options]
    if len(set(labels)) < len(labels):  # two places said alike: their descriptions tell them apart
        labels = [_label(n, places) for n in leg.options]
    listed = ", ".join(labels[:-1]) + f" or {labels[-1]}"
    what = f"'{leg.phrase}'" if leg.phrase else "that"
    context = f" (to {saying.plan(actions, places)})" if len(actions) > 1 else ""
    return Question(
        f"Which place do you mean by {what}{context}: {listed}?",
        "choose",
        actions,
        options=leg.options,
        index=index,
        slot=leg.slot,
    )


def _fill(actions: list[Action], index: int, leg: Leg, places: PlaceIndex | None) -> Question:
    action = actions[index]
    if leg.slot == "obj":
        verb = {"watch": "watch for", "find": "look for"}.get(action.kind, "get")
        return Question(f"What should I {verb}?", "fill", actions, index=index, slot="obj")
    known = f" I know: {_known(places)}." if places and places.places else ""
    things = [saying.thing(a.obj) for a in actions[index:] if a.kind == action.kind and not a.place]
    ask = (
        "Where should I go?"
        if action.kind == "goto"
        else f"Where should I get {' and '.join(things or [saying.thing(action.obj)])} from?"
    )
    return Question(ask + known, "fill", actions, index=index, slot="place")


def unknown_place(phrase: str, places: PlaceIndex | None) -> str:
    known = _known(places) if places and places.places else "none"
    return f"I don't know a place called {phrase!r}. I know: {known}."


def unclear(text: str) -> Reading:
    return Reading(
        "refuse",
        text=f"I didn't understand {text.strip()!r}.",
        intent="unclear",
        score=0.0,
        stage="semantic",
    )


def _known(places: PlaceIndex) -> str:
    """The map's places as a sentence lists them (their human names, never ids)."""
    return ", ".join(places.spoken(name) for name in places.known())


def _known_only(actions: list[Action], places: PlaceIndex | None) -> list[Action]:
    """The actions without what names an unknown place (a delivery to it is dropped)."""
    if places is None:
        return list(actions)
    kept = []
    for action in actions:
        if action.to is not None and places.get(action.to) is None:
            action = replace(action, to=None)
        if action.place is None or places.get(action.place) is not None:
            kept.append(action)
    return kept


def _label(name: str, places: PlaceIndex | None) -> str:
    place = places.get(name) if places else None
    return place.label() if place else name.replace("_", " ")


def spells_a_place(places: PlaceIndex, phrase: str) -> bool:
    """``phrase`` is a place's name or alias ("the kitchen", "front desk"); a word of a place's
    description is not ("where is the charger?" asks for a thing, not the charging dock)."""
    wanted = key(phrase)
    return any(wanted in place.spellings() for place in places.places)


def _sayable(actions: list[Action], places: PlaceIndex | None, placed: bool = True) -> bool:
    """Every object reads as a thing (not a piece of the sentence, not a place's name), and
    (``placed``) every fetch says where from (never "get the X from ?" said back)."""
    return all(
        saying.plausible(a.obj)
        and not (a.obj and places is not None and spells_a_place(places, a.obj))
        and (not placed or a.kind != "fetch" or a.place is not None)
        for a in actions
    )


def _fetch_there(leg: Leg, previous: Action | None) -> bool:
    """A fetch said without a place, right after a drive: from where the drive goes."""
    fetch = leg.action is not None and leg.action.kind == "fetch"
    placeless = leg.status == "missing" and leg.slot == "place"
    return fetch and placeless and previous is not None and previous.kind == "goto"


def _brought_on(action: Action) -> bool:
    """Whether "bring it to Q" can follow ``action``: a fetch, or a search in a place."""
    return action.to is None and (
        action.kind == "fetch" or (action.kind == "find" and bool(action.place))
    )


def share_place(legs: list[Leg]) -> None:
    """ "look for a red mug and a blue box in the meeting room": the place said with the last
    object of a search (a fetch) is the place of the objects before it; "bring the mug and the
    bottle to reception" (or "… and bring them to reception"): so is the destination of a fetch."""
    for i, leg in enumerate(legs):
        if leg.action is None:
            continue
        if leg.more:
            chain = legs[:i]
        elif leg.status == "deliver" and i > 0 and legs[i - 1].more and _THEM.search(leg.text):
            chain = legs[: i - 1]  # the last thing is joined to its delivery when composed
        else:
            continue
        for before in reversed(chain):
            if before.action is None or before.action.kind != leg.action.kind:
                break
            if leg.action.place and not before.action.place:
                before.action = replace(before.action, place=leg.action.place)
                if before.status == "missing" and before.slot == "place":
                    before.status = "ok"
            if leg.action.to and not before.action.to and before.action.kind == "fetch":
                before.action = replace(before.action, to=leg.action.to)
            if not before.more:
                break
