"""The planner prompt file (spec §5.5), re-read at every mission start (hot-editable)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import yaml
from pydantic import BaseModel

from robot_voice_chat.agent.memory import ProcessDoc


class AgentPrompt(BaseModel):
    system: str
    processes_header: str
    nudge: str
    paused_note: str
    distillation: str


async def load_prompt(path: Path) -> AgentPrompt:
    text = await asyncio.to_thread(path.read_text, encoding="utf-8")
    return AgentPrompt.model_validate(yaml.safe_load(text))


def system_prompt(prompt: AgentPrompt, processes: list[ProcessDoc]) -> str:
    if not processes:
        return prompt.system
    docs = "\n\n".join(f"### Process {p.id}: {p.title}\n{p.text}" for p in processes)
    return f"{prompt.system}\n\n{prompt.processes_header}\n\n{docs}"
