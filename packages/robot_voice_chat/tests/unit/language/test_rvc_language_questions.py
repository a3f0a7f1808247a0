"""Questions are answered, not turned into offers to move (issue 32): distance and direction to
a place from the place list and the pose, the time, what the robot is doing, small talk and
thanks; "continue" / "carry on" never stop the robot."""

from __future__ import annotations

from datetime import datetime

import pytest

from robot_language.questions import read_question
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_voice_chat.pipeline.fast_tools import FAST_LOCAL_TOOLS
from robot_voice_chat.services.llm.base import LLMResponse, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat

TOOLS = [*FAST_LOCAL_TOOLS, ToolDefinition(name="navigation.list_locations"),
         ToolDefinition(name="navigation.get_pose")]  # fmt: skip
AT_DOCK_FACING_EAST = '{"x": 0.0, "y": 0.0, "theta": 0.0, "at_location": "dock", "moving": false}'


@pytest.mark.parametrize(
    ("said", "topic", "place"),
    [
        ("how far are you from the kitchen", "distance", "the kitchen"),
        ("how far is the mailroom from here", "distance", "the mailroom"),
        ("which way is reception", "distance", "reception"),
        ("is the kitchen far", "distance", "the kitchen"),
        ("how long would it take to get to the mailroom", "distance", "the mailroom"),
        ("what time is it", "time", None),
        ("what's the time", "time", None),
        ("what are you doing right now", "doing", None),
        ("how are you", "smalltalk", None),
        ("thanks, that's all", "thanks", None),
        ("continue", "resume", None),
        ("carry on", "resume", None),
        ("go on", "resume", None),
        ("please continue the mission", "resume", None),
    ],
)
def test_questions_are_read_with_their_place(said: str, topic: str, place: str | None) -> None:
    asked = read_question(said)
    assert asked is not None
    assert (asked.topic, asked.place) == (topic, place)


@pytest.mark.parametrize("said", ["go on to the kitchen", "continue to the kitchen", "go"])
def test_a_drive_is_not_a_question(said: str) -> None:
    assert read_question(said) is None


@pytest.mark.parametrize(
    ("said", "code"),
    [
        ("how far are you from the kitchen", "answer:distance"),
        ("what time is it", "answer:time"),
        ("look around and tell me what you see", "see"),
        ("thanks, that's all", "answer:thanks"),
        ("continue", "answer:resume"),
        ("carry on", "answer:resume"),
        ("ok you can continue now", "answer:resume"),
        # about itself (issue 38)
        ("what are you holding", "answer:holding"),
        ("what have you got in your gripper", "answer:holding"),
        ("are you carrying anything right now", "answer:holding"),
        ("how is your battery", "answer:battery"),
        ("how much charge have you got left", "answer:battery"),
    ],
)
def test_questions_are_never_read_as_offers_to_move(
    understanding: Understanding, said: str, code: str
) -> None:
    reading = understanding.understand(said, understanding.places(OFFICE_LIST_LOCATIONS))
    assert reading.code() == [code]


async def _answer(chat: RulesChat, text: str, tool_result: str | None = None) -> LLMResponse:
    """One fast-path turn: list_locations, the reply, and (if it calls one) its tool's result."""
    messages = [Message(role="user", content=text)]
    first = await chat.chat(messages, TOOLS)
    messages += [first.as_message(), Message(role="user", tool_results=[ToolResult(
        tool_call_id=first.tool_calls[0].id, content=OFFICE_LIST_LOCATIONS)])]  # fmt: skip
    reply = await chat.chat(messages, TOOLS)
    if not reply.tool_calls or tool_result is None:
        return reply
    messages += [reply.as_message(), Message(role="user", tool_results=[ToolResult(
        tool_call_id=reply.tool_calls[0].id, content=tool_result)])]  # fmt: skip
    return await chat.chat(messages, TOOLS)


async def test_distance_and_direction_come_from_the_map_and_the_pose(
    understanding: Understanding,
) -> None:
    chat = RulesChat(understanding)
    reply = await _answer(chat, "how far are you from the kitchen")
    assert [c.name for c in reply.tool_calls] == ["navigation.get_pose"]
    said = await _answer(chat, "how far are you from the kitchen", AT_DOCK_FACING_EAST)
    # the kitchen is at (9, -3): 9.5 m away, 18 degrees right of a robot facing +x
    assert said.text == "The kitchen is about 9 m from here, straight ahead of me."
    said = await _answer(chat, "how far is alices desk", AT_DOCK_FACING_EAST)
    assert said.text == "Alice's desk is about 10 m from here, ahead of me on the left."
    behind = '{"x": 12.0, "y": 0.0, "theta": 0.0, "moving": false}'
    said = await _answer(chat, "which way is reception", behind)
    assert said.text == "The reception desk is about 8 m from here, behind me."
    here = '{"x": 9.0, "y": -3.0, "theta": 0.0, "at_location": "kitchen", "moving": false}'
    said = await _answer(chat, "where is the kitchen", here)
    assert said.text == "I'm in the kitchen right now."


async def test_the_time_is_said_from_the_clock(understanding: Understanding) -> None:
    moment = datetime(2026, 3, 4, 15, 7).astimezone().timestamp()
    reply = await _answer(RulesChat(understanding, clock=lambda: moment), "what time is it")
    assert reply.text == "It's 3:07 pm."
    assert not reply.tool_calls


async def test_what_i_am_doing_is_read_from_the_pose(understanding: Understanding) -> None:
    chat = RulesChat(understanding)
    said = await _answer(chat, "what are you doing", AT_DOCK_FACING_EAST)
    assert said.text == "Nothing right now: I'm at the charging dock, waiting for a task."
    moving = '{"x": 1.0, "y": 0.0, "moving": true, "destination": "desk_alice"}'
    said = await _answer(chat, "what r u up to", moving)
    assert said.text == "No mission of mine is running, but I'm driving to Alice's desk."


@pytest.mark.parametrize(
    ("said", "answer"),
    [("thank you", "You're welcome."),
     ("thanks, that's all", "You're welcome. I'll be here if you need me."),
     ("how are you", "I'm fine, thanks: charged and ready for a task.")],
)  # fmt: skip
async def test_small_talk_and_thanks_are_answered(
    understanding: Understanding, said: str, answer: str
) -> None:
    reply = await _answer(RulesChat(understanding), said)
    assert reply.text == answer
    assert not reply.tool_calls


@pytest.mark.parametrize("said", ["continue", "carry on", "go on", "keep going"])
async def test_continue_asks_the_brain_whether_anything_is_paused_and_never_stops(
    understanding: Understanding, said: str
) -> None:
    chat = RulesChat(understanding)
    reply = await _answer(chat, said)
    assert [c.name for c in reply.tool_calls] == ["resume_mission"]
    answer = await _answer(chat, said, "There's nothing to continue: no mission is paused.")
    assert answer.text == "There's nothing to continue: no mission is paused."


async def test_continue_without_the_brains_tool_says_there_is_nothing_to_continue(
    understanding: Understanding,
) -> None:
    chat = RulesChat(understanding)
    tools = [t for t in TOOLS if t.name != "resume_mission"]
    messages = [Message(role="user", content="continue")]
    first = await chat.chat(messages, tools)
    messages += [first.as_message(), Message(role="user", tool_results=[ToolResult(
        tool_call_id=first.tool_calls[0].id, content=OFFICE_LIST_LOCATIONS)])]  # fmt: skip
    reply = await chat.chat(messages, tools)
    assert not reply.tool_calls
    assert reply.text.startswith("There's nothing to continue")


@pytest.mark.parametrize(
    ("held", "said"),
    [
        ('{"known": true, "holding": true, "label": "yellow package"}',
         "I'm holding the yellow package."),
        ('{"known": true, "holding": false, "label": null}', "I'm not holding anything."),
        ('{"known": false}', "I can't tell what I'm holding right now: my arm doesn't say."),
    ],
)  # fmt: skip
async def test_what_it_holds_is_read_from_the_gripper(
    understanding: Understanding, held: str, said: str
) -> None:
    tools = [*TOOLS, ToolDefinition(name="manipulation.get_held")]
    chat = RulesChat(understanding)
    messages = [Message(role="user", content="what are you holding")]
    first = await chat.chat(messages, tools)
    messages += [first.as_message(), Message(role="user", tool_results=[ToolResult(
        tool_call_id=first.tool_calls[0].id, content=OFFICE_LIST_LOCATIONS)])]  # fmt: skip
    asked = await chat.chat(messages, tools)
    assert [c.name for c in asked.tool_calls] == ["manipulation.get_held"]
    messages += [asked.as_message(), Message(role="user", tool_results=[ToolResult(
        tool_call_id=asked.tool_calls[0].id, content=held)])]  # fmt: skip
    assert (await chat.chat(messages, tools)).text == said


async def test_without_the_arm_or_a_battery_reading_it_says_so(
    understanding: Understanding,
) -> None:
    chat = RulesChat(understanding)
    holding = await _answer(chat, "what are you holding")
    assert holding.text == "I can't tell what I'm holding: my arm is not connected."
    battery = await _answer(chat, "how is your battery")
    assert not battery.tool_calls
    assert battery.text.startswith("I can't read my battery level")
