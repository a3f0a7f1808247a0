"""Issue 20: "where is my mug?" asked in the present tense. The robot can only say where it last
saw the thing: the answer comes from the episodic memory (last_seen), and going to look is
offered as a question; nothing moves without a yes."""

from __future__ import annotations

import json

import pytest

from robot_language.places import PlaceIndex
from robot_language.recall import (
    LAST_SEEN,
    read_recall,
)
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_stack_testing.brain.episodic_chat import RECALL_TOOLS, recall_turn
from robot_voice_chat.services.llm.base import Message, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat

RED_MUG_SEEN = {
    "query": "red mug",
    "found": True,
    "results": [
        {"label": "red mug", "place": "meeting_room",
         "last_seen": {"ago": "4 min ago", "time": "2026-09-21T15:30:30.000Z"}}
    ],
}  # fmt: skip


@pytest.mark.parametrize(
    ("text", "thing"),
    [
        ("ok so where's the red mug now?", "red mug"),
        ("where is my mug?", "mug"),
        ("where are the scissors?", "scissors"),
        ("where is the parcel right now", "parcel"),
        ("Where's the green bottle?", "green bottle"),
    ],
)
def test_where_is_a_thing_is_its_last_sighting_with_an_offer(text: str, thing: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments, recall.offer) == (LAST_SEEN, {"query": thing}, True)


@pytest.mark.parametrize("text", ["where are you", "where is it", "where r u", "where is everyone"])
def test_where_is_without_a_thing_is_no_sighting(text: str) -> None:
    assert read_recall(text) is None


@pytest.mark.parametrize("text", ["where is the kitchen", "where's the front desk"])
def test_where_is_a_known_place_is_not_a_sighting(text: str) -> None:
    reading = Understanding().understand(text, PlaceIndex.from_result(OFFICE_LIST_LOCATIONS))
    assert reading.recall is None


@pytest.mark.parametrize(("text", "thing"), [("where's the charger?", "charger"),
                                             ("where is the parcel?", "parcel")])  # fmt: skip
def test_a_thing_a_place_description_mentions_is_still_a_thing(text: str, thing: str) -> None:
    """The dock is described as "charging dock", the mailroom as where parcels are collected:
    "where is the parcel" is still its last sighting (and an offer), never a drive there."""
    reading = Understanding().understand(text, PlaceIndex.from_result(OFFICE_LIST_LOCATIONS))
    assert reading.recall is not None
    assert (reading.kind, reading.recall.arguments) == ("answer", {"query": thing})


async def _answered(chat: RulesChat, messages: list[Message], text: str) -> str:
    response = await recall_turn(chat, messages, text)
    [call] = response.tool_calls
    assert (call.name, call.arguments) == (LAST_SEEN, {"query": "red mug"})
    messages.append(response.as_message())
    result = ToolResult(tool_call_id=call.id, content=json.dumps(RED_MUG_SEEN))
    messages.append(Message(role="user", tool_results=[result]))
    answer = await chat.chat(messages, RECALL_TOOLS)
    assert not answer.tool_calls
    messages.append(Message(role="assistant", content=answer.text))
    return answer.text


async def test_the_chat_answers_from_memory_and_only_offers_to_look() -> None:
    chat, messages = RulesChat(Understanding()), []
    text = await _answered(chat, messages, "where's the red mug now?")
    assert text == (
        "I last saw the red mug in the meeting room Harbour 4 min ago (15:30:30 UTC). "
        "Shall I go and look for the red mug?"
    )


async def test_a_yes_to_the_offer_starts_the_search_and_a_no_moves_nothing() -> None:
    chat, messages = RulesChat(Understanding()), []
    await _answered(chat, messages, "where is the red mug?")
    response = await recall_turn(chat, messages, "yes please")
    [call] = response.tool_calls
    assert (call.name, call.arguments["instruction"]) == ("start_mission", "find red mug")
    chat, messages = RulesChat(Understanding()), []
    await _answered(chat, messages, "where is the red mug?")
    response = await recall_turn(chat, messages, "no thanks")
    assert not response.tool_calls
