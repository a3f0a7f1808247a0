"""No server text in the robot's mouth (issue 39 item 5): a drive the base cancelled (e.g. a
supervision lapse) that the server says to resume is a retry — "Resume the drive to …", not
"Detour via …" — and said as the robot's own drive, never "I'll call a drive to …"."""

from __future__ import annotations

import json
from typing import Any

from robot_language.commands import parse
from robot_stack_testing.brain.harness import task_info
from robot_voice_chat.robot_words import check_robot_words
from robot_voice_chat.services.llm.base import ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.plain import suggestion_of
from robot_voice_chat.services.llm.rules.program import MissionProgram
from robot_voice_chat.services.llm.rules.steps import Observation

RESUME = 'call navigate_to("reception") to resume the drive'


def test_a_resume_suggestion_is_said_as_the_robots_own_drive() -> None:
    said = suggestion_of(RESUME, lambda p: "the reception desk")
    assert said == "drive to the reception desk to resume the drive"
    assert "call" not in (said or "")


def _titles(call_args: dict[str, Any]) -> list[str]:
    return [str(s.get("title")) for s in call_args.get("steps", [])]


def test_a_drive_cancelled_under_the_robot_is_resumed_not_detoured() -> None:
    tools = [
        ToolDefinition(name=n) for n in ("navigation.navigate_to", "navigation.list_locations")
    ]
    program = MissionProgram(parse("go to the kitchen"), tools).run()
    next(program)
    places = json.dumps({"locations": [{"name": "kitchen"}]})
    ok = ToolResult(tool_call_id="", content="ok")
    act = program.send(Observation(results=[ok, ToolResult(tool_call_id="", content=places)]))
    drive = ToolResult(tool_call_id="", content=task_info("nav-1"))
    assert [c.name for c in program.send(Observation(results=[drive])).calls] == ["wait_for_events"]
    cancelled = (
        "[task nav-1 navigation.navigate_to] failed CANCELLED (recoverable): navigation to "
        "kitchen was cancelled (supervision lapsed); the robot halted where it is "
        'suggestions: call navigate_to("kitchen") to resume the drive'
    )
    act = program.send(Observation(results=[ok], lines=[cancelled]))
    assert [c.name for c in act.calls] == ["update_plan", "say", "navigation.navigate_to"]
    titles = _titles(act.calls[0].arguments)
    assert "Resume the drive to the kitchen" in titles, titles
    assert not any(t.startswith("Detour") for t in titles), titles
    said = str(act.calls[1].arguments["text"])
    assert said.endswith("I'll drive on to the kitchen."), said
    assert "call" not in said
    assert not check_robot_words([said, *titles])
    assert act.calls[-1].arguments == {"step_id": "s1b", "location": "kitchen"}
