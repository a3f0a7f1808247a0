"""A reading as the rules planner's legs (or the sentence it ends the mission with)."""

from __future__ import annotations

from robot_language.commands import Command
from robot_language.reading import Reading
from robot_voice_chat.services.llm.rules.program import UNDERSTOOD


def legs_of(reading: Reading, text: str) -> tuple[list[Command], str | None]:
    """(legs, None) when the reading acts; else ([], why the planner can't act on it)."""
    if reading.kind == "act" and reading.actions:
        legs = [Command(a.kind, text, a.obj, a.place, a.to) for a in reading.actions]
        return legs, None
    if reading.kind == "cancel" and reading.text:  # only what not to do (issue 32)
        return [], reading.text
    if reading.kind == "ask" and reading.question is not None:
        return [], f"I won't act on a guess: {reading.question.text}"
    said = reading.text if reading.kind == "refuse" and reading.text else ""
    said = said or f"I didn't understand {text.strip()!r}."
    return [], f"I can't do that offline: {said} Offline I understand: {UNDERSTOOD}."
