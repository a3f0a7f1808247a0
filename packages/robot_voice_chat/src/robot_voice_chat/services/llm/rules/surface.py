"""Reading the live tool surface and what the real servers answered: tool presence, task ids,
failures and their suggestions (navigation's locations: ``robot_language.listing``)."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from robot_voice_chat.services.llm.base import ToolDefinition

_NAV_CALL = re.compile(r"""navigate_to\(\s*["']?([\w\- ]+?)["']?\s*\)""")
# Suggestions that need a person (open a door, ask reception) cannot be tried offline.
PERSON_VERBS = ("ask", "check", "wait", "call someone", "get someone", "have someone")


def has_tool(tools: list[ToolDefinition], name: str) -> bool:
    return any(t.name == name for t in tools)


def as_json(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return None


def task_id_of(text: str) -> str | None:
    data = as_json(text)
    task_id = data.get("task_id") if isinstance(data, dict) else None
    return task_id if isinstance(task_id, str) else None


def error_of(text: str) -> str:
    """A tool error's readable part ({"error", "detail"} from the servers, or the text)."""
    data = as_json(text)
    if isinstance(data, dict) and data.get("detail"):
        return f"{data.get('error', 'error')}: {data['detail']}"
    return text[:300]


_RETRY = re.compile(r"^retry(?:[\s,(]|$)")  # "retry", "retry (…)": not "retry_after_s:300"


@dataclass
class Failure:
    code: str
    message: str
    suggestions: list[str]
    recoverable: bool = False

    @property
    def retry_suggested(self) -> bool:
        """The server says the same call may simply be made again (e.g. SERVER_RESTARTED)."""
        return self.recoverable and any(_RETRY.match(s.strip().lower()) for s in self.suggestions)

    @classmethod
    def from_task_info(cls, text: str) -> Failure | None:
        """The ``error`` of a finished task as ``get_task`` returns it."""
        data = as_json(text)
        error = data.get("error") if isinstance(data, dict) else None
        if not isinstance(error, dict):
            return None
        suggestions = error.get("suggestions")
        return cls(
            code=str(error.get("error_code", "FAILED")),
            message=str(error.get("message", "")),
            suggestions=[str(s) for s in suggestions] if isinstance(suggestions, list) else [],
            recoverable=error.get("recoverable") is True,
        )


def detour_legs(suggestion: str) -> list[str] | None:
    """The places a suggestion drives through, or None when it needs a person or no drive."""
    text = suggestion.strip().lower()
    if text.startswith(PERSON_VERBS):
        return None
    legs = [leg.strip() for leg in _NAV_CALL.findall(suggestion)]
    return legs or None
