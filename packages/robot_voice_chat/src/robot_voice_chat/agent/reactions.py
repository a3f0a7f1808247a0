"""Prepared reactions (spec §6): event pattern → tool call, dispatched with zero LLM hops."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, Field

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.task_registry import trigger_of


class EventPattern(BaseModel):
    server: str
    type: str
    task_id: str | None = None
    match: dict[str, Any] = Field(default_factory=dict)

    def matches(self, event: TaskEvent) -> bool:
        if event.server != self.server or event.type != self.type:
            return False
        if self.task_id is not None and event.task_id != self.task_id:
            return False
        trigger = trigger_of(event.payload)
        return all(trigger.get(k) == v for k, v in self.match.items())


class ReactionCall(BaseModel):
    tool: str
    arguments: dict[str, Any] = Field(default_factory=dict)


class Reaction(BaseModel):
    event: EventPattern
    call: ReactionCall
    once: bool = True


@dataclass
class ReactionTable:
    """Per-mission list; ``take`` returns the reactions an event fires (once-entries leave)."""

    reactions: list[Reaction] = field(default_factory=list)

    def add(self, reaction: Reaction) -> None:
        self.reactions.append(reaction)

    def take(self, event: TaskEvent) -> list[Reaction]:
        fired = [r for r in self.reactions if r.event.matches(event)]
        self.reactions = [r for r in self.reactions if not (r.once and r in fired)]
        return fired
