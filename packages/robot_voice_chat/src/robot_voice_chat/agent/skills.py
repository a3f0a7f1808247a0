"""Vision skills the brain started and has not stopped (so a safety stop can stop them).

Skills come from a skill server's ``instantiate_skill`` / ``instantiate_raw_skill`` results
(``{"skill_id": ...}``) and leave on its ``stop_skill``. Skills the vision node runs by its own
configuration (e.g. an ambient scene describer) are not the brain's to stop.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

START_TOOLS = frozenset({"instantiate_skill", "instantiate_raw_skill"})
STOP_TOOL = "stop_skill"


@dataclass(frozen=True)
class ActiveSkill:
    server: str
    skill_id: str

    @property
    def stop_tool(self) -> str:
        return f"{self.server}.{STOP_TOOL}"


class SkillLedger:
    def __init__(self) -> None:
        self._active: dict[tuple[str, str], ActiveSkill] = {}

    def note(self, dotted: str, arguments: dict[str, Any], text: str, is_error: bool) -> None:
        """Record what a tool call did to the set of running skills."""
        server, _, tool = dotted.partition(".")
        if is_error:
            return
        if tool in START_TOOLS:
            skill_id = _skill_id(text)
            if skill_id is not None:
                self._active[(server, skill_id)] = ActiveSkill(server, skill_id)
        elif tool == STOP_TOOL:
            self.forget(server, str(arguments.get("skill_id", "")))

    def forget(self, server: str, skill_id: str) -> None:
        self._active.pop((server, skill_id), None)

    def active(self) -> list[ActiveSkill]:
        return list(self._active.values())


def _skill_id(text: str) -> str | None:
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if not isinstance(data, dict) or data.get("prewarm"):
        return None
    skill_id = data.get("skill_id")
    return skill_id if isinstance(skill_id, str) and skill_id else None
