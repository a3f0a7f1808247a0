"""The pieces a mission program is made of: the calls of one planner step (:class:`Act`),
what came back (:class:`Observation`), the plan's steps and how a program ends."""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any

from robot_voice_chat.services.llm.base import ToolResult


@dataclass
class Call:
    name: str
    arguments: dict[str, Any] = field(default_factory=dict)


@dataclass
class Act:
    calls: list[Call]
    text: str = ""


@dataclass
class Observation:
    results: list[ToolResult] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)
    paused_reply: str | None = None


@dataclass
class Outcome:
    kind: str  # done | failed | watch_event | paused
    line: str = ""


Program = Generator[Act, Observation, None]
Steps = Generator[Act, Observation, Any]


class Finished(Exception):
    def __init__(self, outcome: str, summary: str) -> None:
        super().__init__(summary)
        self.outcome, self.summary = outcome, summary


@dataclass
class PlanStep:
    id: str
    title: str
    tool: str | None = None
