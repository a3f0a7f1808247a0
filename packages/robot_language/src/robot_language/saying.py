"""What the robot says back about a request: whole sentences a person would say, with places
by their human names ("look for the package in the mailroom", "get the green bottle from the
kitchen and bring it to Bob's desk"), never the input's words pasted into a template."""

from __future__ import annotations

from typing import Literal

from robot_language.config_file import word_lists
from robot_language.places import PlaceIndex, located
from robot_language.reading import Action, Question


def place_of(name: str | None, places: PlaceIndex | None) -> str:
    """A map id as a sentence says it ("the kitchen", "Alice's desk")."""
    if not name:
        return ""
    return places.spoken(name) if places is not None else f"the {name.replace('_', ' ')}"


def thing(obj: str | None) -> str:
    """An object with its article ("the red mug"); a person or "someone" as said."""
    if not obj:
        return "it"
    first = obj.split(" ", 1)[0]
    if first in ("the", "a", "an", "my", "your", "someone", "somebody", "anyone", "people"):
        return obj
    if first.endswith("'s"):  # "bob's mug": whose it is says which
        return obj
    return f"the {obj}"


def said(action: Action, places: PlaceIndex | None) -> str:
    """One action as the robot says it ("go to Alice's desk")."""
    where = place_of(action.place, places)
    if action.kind == "goto":
        return f"go to {where}"
    if action.kind == "find":
        return f"look for {thing(action.obj)}" + (f" {located(where)}" if action.place else "")
    if action.kind == "fetch":
        return f"get {thing(action.obj)} from {where}" + (
            f" and bring it to {place_of(action.to, places)}" if action.to else ""
        )
    if action.kind == "watch":
        return f"watch for {action.obj}"
    if action.kind == "pick":
        return f"pick up the {action.obj}"
    if action.kind == "put":
        what = f"the {action.obj}" if action.obj else "it"
        where = f" at the {action.place.replace('_', ' ')}" if action.place else ""
        return f"put {what} down{where}"
    if action.kind == "release":
        return "hand it over"
    return "tell you what I see"


def plan(actions: list[Action], places: PlaceIndex | None) -> str:
    """The actions in order, as one sentence's predicate."""
    return ", then ".join(said(a, places) for a in actions)


def confirm(actions: list[Action], places: PlaceIndex | None) -> str:
    """The yes/no question that says a reading back before anything is done."""
    return f"Do you want me to {plan(actions, places)}? (yes or no)"


_WORDS = word_lists("words", "not_a_thing", "cut_off")
CUT_OFF = _WORDS["cut_off"]  # a phrase that ends on one of these was cut off


def plausible(obj: str | None) -> bool:
    """Whether ``obj`` reads as a thing to say back ("the yellow package"), not a piece of the
    sentence ("there's a package", "tell me what you see")."""
    if obj is None:
        return True
    said = obj.split()
    if not said or said[-1] in CUT_OFF | {"in", "on"}:  # "bob's desk far from"
        return False
    return len(said) <= 5 and not _WORDS["not_a_thing"] & set(said)


def did_you_mean(
    actions: list[Action],
    index: int,
    slot: Literal["place", "obj", "to"],
    name: str,
    places: PlaceIndex | None,
) -> Question:
    """A place said a little wrong and one place near it: "Did you mean the kitchen?"; yes
    does the request with that place."""
    done = Question("", "confirm", actions, index=index, slot=slot).complete(name)
    where = place_of(name, places)
    whole = f" ({plan(done, places)})" if len(done) > 1 else ""
    return Question(f"Did you mean {where}{whole}? (yes or no)", "confirm", done)
