"""The rules chat with the understanding layer: the live places are read first, a sure request
goes to start_mission with every leg, an unsure one becomes one question answered next turn."""

from __future__ import annotations

import pytest

from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_voice_chat.pipeline.fast_tools import FAST_LOCAL_TOOLS
from robot_voice_chat.services.llm.base import LLMResponse, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat

TOOLS = [*FAST_LOCAL_TOOLS, ToolDefinition(name="navigation.list_locations"),
         ToolDefinition(name="navigation.get_pose"),
         ToolDefinition(name="skill_control.instantiate_skill")]  # fmt: skip


async def _turn(chat: RulesChat, history: list[Message], text: str) -> LLMResponse:
    """One fast-path turn as the pipeline runs it: list_locations, then the reply."""
    messages = [*history, Message(role="user", content=text)]
    first = await chat.chat(messages, TOOLS)
    assert [c.name for c in first.tool_calls] == ["navigation.list_locations"]
    messages += [
        first.as_message(),
        Message(
            role="user",
            tool_results=[
                ToolResult(tool_call_id=first.tool_calls[0].id, content=OFFICE_LIST_LOCATIONS)
            ],
        ),
    ]
    reply = await chat.chat(messages, TOOLS)
    history += [Message(role="user", content=text), Message(role="assistant", content=reply.text)]
    return reply


async def test_a_sequence_goes_to_the_planner_with_every_leg_in_order(
    understanding: Understanding,
) -> None:
    reply = await _turn(RulesChat(understanding), [], "Go to the kitchen and then to reception")
    [call] = reply.tool_calls
    assert call.name == "start_mission"
    assert call.arguments["instruction"] == "go to kitchen, then go to reception"


async def test_ask_then_answer_then_act(understanding: Understanding) -> None:
    chat, history = RulesChat(understanding), []
    question = await _turn(chat, history, "go to the desk")
    assert not question.tool_calls
    assert "Alice's desk" in question.text  # places by the names people use (issue 31)
    assert "Bob's desk" in question.text
    assert "desk_" not in question.text
    assert "desk bob" not in question.text
    reply = await _turn(chat, history, "Bob's")
    [call] = reply.tool_calls
    assert call.arguments["instruction"] == "go to desk_bob"


async def test_never_mind_cancels_the_question(understanding: Understanding) -> None:
    chat, history = RulesChat(understanding), []
    question = await _turn(chat, history, "go to the kitchen then sing a song")
    assert not question.tool_calls
    assert "(yes or no)" in question.text
    reply = await _turn(chat, history, "never mind")
    assert not reply.tool_calls
    assert "won't do anything" in reply.text
    after = await _turn(chat, history, "yes")  # nothing pending any more: no action
    assert not after.tool_calls


async def test_a_partial_sequence_is_confirmed_as_a_whole(understanding: Understanding) -> None:
    chat, history = RulesChat(understanding), []
    question = await _turn(chat, history, "go to the kitchen and then to the garage")
    assert "garage" in question.text
    assert not question.tool_calls
    reply = await _turn(chat, history, "yes")
    assert reply.tool_calls[0].arguments["instruction"] == "go to kitchen"


async def test_an_unknown_place_is_refused_naming_the_known_ones(
    understanding: Understanding,
) -> None:
    reply = await _turn(RulesChat(understanding), [], "go to the garage")
    assert not reply.tool_calls
    assert "garage" in reply.text
    assert "mailroom" in reply.text


async def test_questions_are_answered_from_the_tools(understanding: Understanding) -> None:
    chat = RulesChat(understanding)
    places = await _turn(chat, [], "Which places do you know?")
    assert "Alice's desk" in places.text  # by its human name (issue 31)
    where = await _turn(chat, [], "Where are you?")
    [call] = where.tool_calls
    assert call.name == "navigation.get_pose"
    answer = await chat.chat(
        [Message(role="user", content="Where are you?"), where.as_message(),
         Message(role="user", tool_results=[ToolResult(tool_call_id=call.id,
                 content='{"x": 9.0, "y": -3.0, "at_location": "kitchen", "moving": false}')])],
        TOOLS,
    )  # fmt: skip
    assert answer.text == "I'm in the kitchen."


@pytest.mark.parametrize(
    ("pose", "said"),
    [
        ('{"at_location": "desk_alice", "moving": false}', "I'm at Alice's desk."),
        ('{"at_location": "reception", "moving": false}', "I'm at the reception desk."),
        ('{"at_location": "mailroom", "moving": false}', "I'm in the mailroom."),
        ('{"destination": "desk_alice", "moving": true}', "I'm driving to Alice's desk."),
    ],
)
async def test_where_i_am_is_said_with_the_maps_human_place_names(
    understanding: Understanding, pose: str, said: str
) -> None:
    chat = RulesChat(understanding)
    where = await _turn(chat, [], "Where are you?")
    [call] = where.tool_calls
    answer = await chat.chat(
        [Message(role="user", content="Where are you?"), where.as_message(),
         Message(role="user", tool_results=[ToolResult(tool_call_id=call.id, content=pose)])],
        TOOLS,
    )  # fmt: skip
    assert answer.text == said


async def test_call_ids_renamed_on_the_way_still_reach_the_right_step(
    understanding: Understanding,
) -> None:
    """Behind an OpenAI-compatible API the server names the calls (the robot preset's fast
    path): the places answer must still be read as the places, not as 'Done.'."""
    chat = RulesChat(understanding)
    messages = [Message(role="user", content="Please fetch the package from the mailroom.")]
    first = await chat.chat(messages, TOOLS)
    renamed = first.tool_calls[0].model_copy(update={"id": "call_from_the_server"})
    messages += [
        Message(role="assistant", tool_calls=[renamed]),
        Message(
            role="user",
            tool_results=[
                ToolResult(tool_call_id="call_from_the_server", content=OFFICE_LIST_LOCATIONS)
            ],
        ),
    ]
    reply = await chat.chat(messages, TOOLS)
    assert [c.name for c in reply.tool_calls] == ["start_mission"]


@pytest.mark.parametrize("labels", ['{"labels": ["thermos", "coffee_mug"]}', "not json"])
async def test_what_the_robot_has_seen_is_read_with_the_places(
    understanding: Understanding, labels: str
) -> None:
    """With memory running, episodic.known_labels is read beside the places: a thing the
    camera has seen, misspelt, is fetched by its name; an unreadable answer changes nothing."""
    chat = RulesChat(understanding)
    tools = [*TOOLS, ToolDefinition(name="episodic.known_labels"),
             ToolDefinition(name="start_mission")]  # fmt: skip
    messages = [Message(role="user", content="fetch the thermoss from the kitchen")]
    first = await chat.chat(messages, tools)
    places, seen = first.tool_calls
    assert (places.name, seen.name) == ("navigation.list_locations", "episodic.known_labels")
    answers = [
        ToolResult(tool_call_id=places.id, content=OFFICE_LIST_LOCATIONS),
        ToolResult(tool_call_id=seen.id, content=labels),
    ]
    messages += [first.as_message(), Message(role="user", tool_results=answers)]
    reply = await chat.chat(messages, tools)
    [call] = reply.tool_calls
    thing = "thermos" if labels.startswith("{") else "thermoss"
    assert call.arguments["instruction"] == f"fetch {thing} from kitchen"
