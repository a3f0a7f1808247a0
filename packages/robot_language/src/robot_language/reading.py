"""What the understanding layer made of a request: actions to take, or one question to ask, or
a refusal, or a question the robot answers from its tools."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

from robot_language.recall import Recall

ActionKind = Literal["goto", "find", "fetch", "watch", "see", "pick", "put", "release"]
ReadingKind = Literal["act", "ask", "refuse", "answer", "stop", "greet", "cancel"]


@dataclass(frozen=True)
class Action:
    kind: ActionKind
    place: str | None = None  # goto's destination; find/fetch's place to go first
    obj: str | None = None
    to: str | None = None  # fetch: where to bring it

    def instruction(self) -> str:
        """The action in the exact grammar's words (the rules planner parses it back)."""
        if self.kind == "goto":
            return f"go to {self.place}"
        if self.kind == "find":
            return f"find {self.obj}" + (f" in {self.place}" if self.place else "")
        if self.kind == "fetch":
            return f"fetch {self.obj} from {self.place}" + (
                f", then bring it to {self.to}" if self.to else ""
            )
        if self.kind == "watch":
            return f"watch for {self.obj}"
        if self.kind == "pick":
            return f"pick up {self.obj}"
        if self.kind == "put":
            return f"put {self.obj or 'it'} down" + (f" at {self.place}" if self.place else "")
        if self.kind == "release":
            return "hand it over"
        return "what do you see"

    def code(self) -> str:
        """Compact form used by the phrasing sets: goto:kitchen, fetch:mug@kitchen>dock."""
        if self.kind == "see":
            return "see"
        if self.kind == "goto":
            return f"goto:{self.place}"
        text = f"{self.kind}:{self.obj}" if self.obj else self.kind
        if self.place:
            text += f"@{self.place}"
        if self.to:
            text += f">{self.to}"
        return text


def instruction_of(actions: list[Action]) -> str:
    return ", then ".join(a.instruction() for a in actions)


@dataclass(frozen=True)
class Question:
    """One clarifying question and how its answer completes the request.

    ``choose``: the answer picks one of ``options`` (place names) for ``slot`` of action
    ``index``; ``confirm``: yes acts ``actions`` as they are; ``fill``: the answer is the
    missing ``slot`` (place or object) of action ``index``."""

    text: str
    mode: Literal["choose", "confirm", "fill"]
    actions: list[Action] = field(default_factory=list)
    options: list[str] = field(default_factory=list)
    index: int = 0
    slot: Literal["place", "obj", "to"] = "place"

    def complete(self, value: str) -> list[Action]:
        """The actions with the slot asked about filled; a place answers for every later
        action of that kind still without one ("where should I get the mug and the bottle
        from?")."""
        actions = list(self.actions)
        asked = actions[self.index]
        for i, action in enumerate(actions):
            same = self.slot == "place" and i > self.index and action.kind == asked.kind
            if i == self.index or (same and action.place is None):
                actions[i] = _with(action, self.slot, value)
        return actions


@dataclass(frozen=True)
class Reading:
    kind: ReadingKind
    actions: list[Action] = field(default_factory=list)
    question: Question | None = None
    text: str = ""  # a refusal's sentence; an answer that needs no tool (small talk, thanks)
    topic: str = ""  # answer: where | places | abilities | history | greet | distance | time |
    # doing | smalltalk | thanks | resume | <site intent>
    recall: Recall | None = None  # topic history: the episodic call that answers it
    intent: str = ""
    score: float = 1.0
    stage: Literal["grammar", "semantic", "answer"] = "grammar"
    about: str | None = None  # answer: the place a question is about (a map id)

    def code(self) -> list[str]:
        if self.kind == "act":
            return [a.code() for a in self.actions]
        if self.kind == "answer":
            return [f"answer:{self.recall.code() if self.recall else self.topic}"]
        return [self.kind]


def _with(action: Action, slot: str, value: str) -> Action:
    if slot == "obj":
        return replace(action, obj=value)
    if slot == "to":
        return replace(action, to=value)
    return replace(action, place=value)
