"""Telling the person, once, that the robot sees with its on-board detector (issue 30).

Perception results say who answered (``grounder_fallback: true`` when the vision node's local
fallback stood in for the cloud grounder). The first such result of an outage makes the robot
say so once; a result the primary answered again ends the outage (the next one is told too).
"""

from __future__ import annotations

import json
from typing import Any

FALLBACK_SENTENCE = "The cloud is unreachable; I'm using the on-board detector."


def fallback_flags(text: str) -> list[bool]:
    """Every ``grounder_fallback`` value in a tool result's JSON, outermost first."""
    try:
        data = json.loads(text)
    except ValueError:
        return []
    found: list[bool] = []

    def walk(value: Any) -> None:
        if isinstance(value, dict):
            flag = value.get("grounder_fallback")
            if isinstance(flag, bool):
                found.append(flag)
            for item in value.values():
                walk(item)
        elif isinstance(value, list):
            for item in value:
                walk(item)

    walk(data)
    return found


class FallbackNotice:
    """Whether to tell the person now (once per outage)."""

    def __init__(self) -> None:
        self.told = False

    def sentence_for(self, tool: str, text: str) -> str | None:
        if not tool.startswith("perception."):
            return None
        flags = fallback_flags(text)
        if not flags:
            return None
        if any(flags):
            if self.told:
                return None
            self.told = True
            return FALLBACK_SENTENCE
        self.told = False  # the cloud answered again
        return None
