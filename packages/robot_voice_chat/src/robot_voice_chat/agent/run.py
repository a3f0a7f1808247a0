"""Per-mission runtime state of the executor loop."""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field
from typing import Literal

from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.agent.prompt import AgentPrompt
from robot_voice_chat.agent.reactions import ReactionTable
from robot_voice_chat.services.llm.base import LLMResponse, Message

Outcome = Literal["succeeded", "failed", "cancelled"]


class MissionFailure(Exception):
    """Ends a mission as failed; ``code`` is e.g. BUDGET_STEPS or NO_PROGRESS."""

    def __init__(self, code: str, summary: str) -> None:
        super().__init__(summary)
        self.code = code
        self.summary = summary


class MissionBusyError(RuntimeError):
    def __init__(self, mission: Mission) -> None:
        super().__init__(f"mission {mission.id} is {mission.state}: {mission.instruction}")
        self.mission = mission


class MissionsDisabledError(RuntimeError):
    pass


class SafetyStopLatchedError(MissionsDisabledError):
    """A new mission while the software stop is latched; the message says why and what to do."""


@dataclass
class MissionRun:
    mission: Mission
    prompt: AgentPrompt
    messages: list[Message] = field(default_factory=list)
    reactions: ReactionTable = field(default_factory=ReactionTable)
    inbox: list[str] = field(default_factory=list)
    wakeup: asyncio.Event = field(default_factory=asyncio.Event)
    started: float = field(default_factory=time.monotonic)
    suspended: bool = False
    awaiting_user: bool = False
    nudged: bool = False
    llm_steps: int = 0
    cost_usd: float = 0.0
    finished: tuple[Outcome, str] | None = None
    task: asyncio.Task[None] | None = None
    llm_call: asyncio.Task[LLMResponse] | None = None
    # set once the mission is over and told (its summary said): the next one may start
    released: asyncio.Event = field(default_factory=asyncio.Event)

    def post(self, line: str) -> None:
        self.inbox.append(line)
        self.wakeup.set()
