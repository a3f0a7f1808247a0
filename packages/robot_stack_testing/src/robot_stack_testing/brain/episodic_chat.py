"""Asking the rules chat questions about the past in tests (issue 20): the tools a brain with the
episodic server offers, the arguments of a sightings-only digest, and one chat turn that answers
the chat's ``list_locations`` with the office map before it reaches its episodic call."""

from __future__ import annotations

from robot_language.recall import LAST_SEEN, POSE_AT, WHAT_HAPPENED
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_voice_chat.services.llm.base import LLMResponse, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.chat import LIST_LOCATIONS, RulesChat

RECALL_TOOLS = [
    ToolDefinition(name=n)
    for n in (
        WHAT_HAPPENED,
        LAST_SEEN,
        POSE_AT,
        LIST_LOCATIONS,
        "skill_control.instantiate_skill",
        "start_mission",
    )
]
SIGHTINGS_ONLY = {"kinds": ["sightings"], "max_items": 100}


async def recall_turn(
    chat: RulesChat, messages: list[Message], text: str, locations: str = OFFICE_LIST_LOCATIONS
) -> LLMResponse:
    """One turn up to its episodic call (or its answer): the places are read first."""
    messages.append(Message(role="user", content=text))
    response = await chat.chat(messages, RECALL_TOOLS)
    if response.tool_calls and response.tool_calls[0].name == LIST_LOCATIONS:
        messages.append(response.as_message())
        result = ToolResult(tool_call_id=response.tool_calls[0].id, content=locations)
        messages.append(Message(role="user", tool_results=[result]))
        response = await chat.chat(messages, RECALL_TOOLS)
    return response
