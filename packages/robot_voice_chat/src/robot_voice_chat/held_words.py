"""What the robot says about what its gripper holds (issue 39 item 3): pure wording, shared by
the brain's end of a mission (``agent/holding.py``) and the rules planner's searches and picks.

"I'm still holding the yellow package, near the east corridor. Should I put it down here, or
take it somewhere?" — the held thing as the arm's server names it, where the robot is as the
nearest named place, and never "It is still in the mailroom" about the thing in its gripper.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from robot_language.places import PlaceIndex, located

AT_PLACE_M = 1.0
"""Within this of a named place the robot is "in the mailroom"; farther, "near" it."""
QUESTION = "Should I put it down here, or take it somewhere?"


@dataclass(frozen=True)
class Held:
    """The arm's server's word: ``known`` False when it did not answer (then say nothing)."""

    known: bool
    label: str | None = None


def held_from(content: str, is_error: bool) -> Held:
    """``get_held``'s answer: ``{"known", "holding", "label"}``."""
    if is_error:
        return Held(False)
    try:
        data: Any = json.loads(content)
    except ValueError:
        return Held(False)
    if not isinstance(data, dict) or data.get("known") is False:
        return Held(False)
    label = data.get("label")
    if data.get("holding") and isinstance(label, str) and label.strip():
        return Held(True, label.strip())
    return Held(True, None)


def whereabouts_of(listed: str) -> str | None:
    """Where the robot is, from ``list_locations``' answer (each place's ``distance_m`` from
    the robot): "in the mailroom" / "at reception" within ``AT_PLACE_M`` of the nearest named
    place, "near the east corridor" farther away; None without distances."""
    index = PlaceIndex.from_result(listed)
    known = [p for p in index.places if p.distance_m is not None]
    if not known:
        return None
    place = min(known, key=lambda p: p.distance_m or 0.0)
    spoken = place.spoken()
    if (place.distance_m or 0.0) <= AT_PLACE_M:
        return f"here {located(spoken)}"
    return f"near {spoken}"


def still_holding(label: str, where: str | None) -> str:
    """ "I'm still holding the yellow package, near the east corridor. Should I put it down
    here, or take it somewhere?" """
    place = f", {where}" if where else ""
    return f"I'm still holding the {label}{place}. {QUESTION}"


def held_sentence(held: Held) -> str:
    """The answer to "what are you holding", from ``get_held``."""
    if not held.known:
        return "I can't tell what I'm holding right now: my arm doesn't say."
    return holding_answer(held.label) if held.label else "I'm not holding anything."


def holding_answer(label: str) -> str:
    """A search for something the gripper holds is answered from the gripper."""
    return f"I'm holding the {label}."


def names_it(obj: str, label: str) -> bool:
    """Whether ``obj`` (as a person said it: "package", "the yellow package") names ``label``
    (the arm's server's: "yellow package"): every word of it is one of the label's."""
    said = {w for w in re.findall(r"[a-z]+", obj.lower()) if w not in ("the", "a", "an", "my")}
    return bool(said) and said <= set(re.findall(r"[a-z]+", label.lower()))


def _sentences(text: str) -> list[str]:
    return [s for s in re.split(r"(?<=[.!?])\s+", text.strip()) if s]


_STILL_THERE = re.compile(r"\b(?:is|remains|stays) still (?:in|at|on)\b|\bis still there\b")


def without_false_places(summary: str, label: str) -> str:
    """``summary`` without a sentence that puts the held thing somewhere ("It is still in the
    mailroom.", "The yellow package is still at reception.")."""
    kept = []
    for sentence in _sentences(summary):
        if _STILL_THERE.search(sentence):
            subject = sentence.split(" is ", 1)[0].split(" remains ", 1)[0]
            if subject.lower() == "it" or names_it(subject, label):
                continue
        kept.append(sentence)
    return " ".join(kept)


def says_it_holds(summary: str, label: str) -> bool:
    """The summary already tells that the gripper holds ``label``."""
    low = summary.lower()
    return label.lower() in low and bool(re.search(r"\b(?:still )?hold(?:s|ing)?\b", low))
