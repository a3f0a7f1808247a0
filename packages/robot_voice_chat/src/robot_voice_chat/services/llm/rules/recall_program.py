"""A question about the past asked as a mission (the rules planner, e.g. in degraded mode):
one episodic call, then the answer as the mission's summary. Never a motion."""

from __future__ import annotations

from robot_language.recall import Recall
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.llm.rules.recollection import (
    NOT_CONNECTED,
    Names,
    by_id,
    recollection,
)
from robot_voice_chat.services.llm.rules.steps import Act, Call, Program
from robot_voice_chat.services.llm.rules.surface import has_tool


def recall_program(
    recall: Recall, tools: list[ToolDefinition], resumed: bool = False, names: Names = by_id
) -> Program:
    """``names``: how the answer says places (the live place list's human names)."""
    prefix = "r" if resumed else "s"
    look, tell = f"{prefix}1", f"{prefix}2"
    if not has_tool(tools, recall.tool):
        outcome, summary = "failed", NOT_CONNECTED
    else:
        steps = [
            {"id": look, "title": "Look it up in my memory", "tool": recall.tool},
            {"id": tell, "title": "Tell the user"},
        ]
        plan = "update_plan" if resumed else "set_plan"
        observation = yield Act(
            [Call(plan, {"steps": steps}), Call(recall.tool, {**recall.arguments, "step_id": look})]
        )
        results = observation.results[1:]
        if results:
            result = results[0]
            summary = recollection(recall, recall.tool, result.content, result.is_error, names)
            outcome = "failed" if result.is_error else "succeeded"
        else:
            outcome, summary = "failed", "My memory gave no answer."
    calls = [Call("finish_mission", {"outcome": outcome, "summary": summary})]
    if outcome == "succeeded":
        calls.insert(0, Call("mark_step", {"step_id": tell, "status": "succeeded"}))
    while True:
        yield Act(calls)
