"""Questions about the past in the words operators use (issue 20, held-out set): texting
shorthand, the thing as subject, spoken clock times, ranges, follow-ups read against the
previous question, places by their human names; a question about the past the grammar cannot
read gets an honest answer and never becomes an action."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robot_language.places import PlaceIndex, located
from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    follow_up_recall,
    read_recall,
)
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import NOT_READ_RECALL, Understanding
from robot_stack_testing.brain.episodic_chat import RECALL_TOOLS, SIGHTINGS_ONLY, recall_turn
from robot_voice_chat.services.llm.base import Message, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.recollection import recollection


@pytest.mark.parametrize(
    ("text", "tool", "arguments"),
    [
        ("u seen my keys?", LAST_SEEN, {"query": "keys"}),
        ("when was the last time the red mug showed up", LAST_SEEN, {"query": "red mug"}),
        ("where's the last place you saw the scissors", LAST_SEEN, {"query": "scissors"}),
        ("any idea where the charger is?", LAST_SEEN, {"query": "charger"}),
        ("is my mug still in the kitchen?", LAST_SEEN, {"query": "mug", "place": "kitchen"}),
        ("how long did you see the scissors for?", LAST_SEEN, {"query": "scissors"}),
        ("how many minutes ago did you see the parcel", LAST_SEEN, {"query": "parcel"}),
        ("did you notice a package in the mailroom earlier", LAST_SEEN,
         {"query": "parcel", "place": "mailroom"}),
        ("when did you first see the parcel today?", LAST_SEEN, {"query": "parcel", "n": 20}),
        ("where were you around half past two", POSE_AT, {"time": "2:30pm"}),
        ("where were you at quarter to nine", POSE_AT, {"time": "8:45am"}),
        ("where were you at three in the afternoon", POSE_AT, {"time": "3pm"}),
        ("what were you up to at 14:27?", POSE_AT, {"time": "14:27"}),
        ("what happened between 3:30 and 3:35 pm?", WHAT_HAPPENED,
         {"start": "3:30pm", "end": "3:35pm", "max_items": 100}),
        ("anything interesting in the last quarter hour", WHAT_HAPPENED,
         {"start": "-900s", "max_items": 100}),
        ("what do you remember seeing in the last 90 seconds", WHAT_HAPPENED,
         {**SIGHTINGS_ONLY, "start": "-90s"}),
        ("what was in the kitchen when you were there", WHAT_HAPPENED,
         {**SIGHTINGS_ONLY, "place": "kitchen", "start": "-24h"}),
    ],
)  # fmt: skip
def test_operator_wording_is_one_episodic_call(
    text: str, tool: str, arguments: dict[str, Any]
) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (tool, arguments)


def test_a_follow_up_is_read_against_the_previous_question() -> None:
    seen = read_recall("have you seen the scissors?")
    assert seen is not None
    laptop = follow_up_recall("and the laptop?", seen)
    assert laptop is not None
    assert laptop.arguments == {"query": "laptop"}
    assert follow_up_recall("where was that?", seen) == seen
    pose = read_recall("where were you at 3 pm")
    assert pose is not None
    earlier = follow_up_recall("what about 2:24 pm?", pose)
    assert earlier is not None
    assert earlier.arguments == {"time": "2:24pm"}
    kitchen = read_recall("what did you see in the kitchen today?")
    assert kitchen is not None
    mailroom = follow_up_recall("and in the mailroom?", kitchen)
    assert mailroom is not None
    assert mailroom.arguments == {**SIGHTINGS_ONLY, "place": "mailroom", "start": "00:00"}
    assert follow_up_recall("go to the kitchen", seen) is None
    assert follow_up_recall("and the kitchen?", pose) is None  # a place after a pose: not read


@pytest.mark.parametrize(
    "text",
    ["is my mug still in the kitchen?", "where's the last place you saw the scissors",
     "when did the thing you saw earlier go?"],
)  # fmt: skip
def test_a_question_about_the_past_never_becomes_an_action(
    understanding: Understanding, text: str
) -> None:
    reading = understanding.understand(text)
    assert reading.kind in ("answer", "refuse"), reading
    if reading.kind == "refuse":
        assert reading.text == NOT_READ_RECALL


def test_requests_that_mention_the_past_stay_requests(understanding: Understanding) -> None:
    assert understanding.understand("bring me the mug you saw in the kitchen").kind == "act"


def test_the_first_sighting_on_record_is_said_when_asked_for_the_first() -> None:
    recall = read_recall("when did you first see the parcel?")
    results = [
        {"label": "parcel", "place": "mailroom", "first_seen": {"ago": "10 min ago",
         "time": "2026-09-21T15:33:20.000Z"}, "last_seen": {"ago": "9 min ago"}},
        {"label": "parcel", "place": "mailroom", "first_seen": {"ago": "12 min ago",
         "time": "2026-09-21T15:31:20.000Z"}, "last_seen": {"ago": "11 min ago"}},
    ]  # fmt: skip
    answer = {"found": True, "results": results}
    assert recollection(recall, LAST_SEEN, json.dumps(answer), False) == (
        "The first time I have on record, I saw the parcel in the mailroom 12 min ago "
        "(15:31:20 UTC); I last saw it in the mailroom 9 min ago."
    )


async def test_the_chat_reads_a_follow_up_from_the_conversation(
    understanding: Understanding,
) -> None:
    chat, messages = RulesChat(understanding), []
    first = await recall_turn(chat, messages, "have you seen the scissors?")
    assert first.tool_calls[0].arguments == {"query": "scissors"}
    messages.append(Message(role="assistant", content="I last saw the scissors ..."))
    second = await recall_turn(chat, messages, "and the laptop?")
    assert [(c.name, c.arguments) for c in second.tool_calls] == [(LAST_SEEN, {"query": "laptop"})]


async def test_a_place_is_resolved_by_its_human_name_or_said_unknown(
    understanding: Understanding,
) -> None:
    chat = RulesChat(understanding)
    alice = await recall_turn(chat, [], "what did you see at Alice's desk")
    assert alice.tool_calls[0].arguments["place"] == "desk_alice"
    garage = await recall_turn(chat, [], "what did you see in the garage today")
    assert not garage.tool_calls
    assert garage.text.startswith(
        "I don't know a place called 'garage'. I know: the charging dock,"
    )


@pytest.mark.parametrize(
    ("name", "spoken"),
    [("desk_alice", "Alice's desk"), ("dock", "the charging dock"), ("kitchen", "the kitchen"),
     ("reception", "the reception desk"), ("corridor_b", "the east corridor"),
     ("meeting_room", "the meeting room Harbour"), ("garage_2", "the garage 2")],
)  # fmt: skip
def test_a_place_is_said_by_its_human_name_else_its_id_with_spaces(name: str, spoken: str) -> None:
    places = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS)
    assert places.spoken(name) == spoken


@pytest.mark.parametrize(
    ("spoken", "said"),
    [("the kitchen", "in the kitchen"), ("the mailroom", "in the mailroom"),
     ("the meeting room Harbour", "in the meeting room Harbour"),
     ("the east corridor", "in the east corridor"), ("the corridor b", "in the corridor b"),
     ("the open-plan office", "in the open-plan office"), ("the Lab 3", "in the Lab 3"),
     ("reception", "at reception"), ("the reception desk", "at the reception desk"),
     ("Alice's desk", "at Alice's desk"), ("the charging dock", "at the charging dock"),
     ("the desk bob", "at the desk bob"), ("the store room", "in the store room")],
)  # fmt: skip
def test_rooms_are_in_and_points_are_at(spoken: str, said: str) -> None:
    assert located(spoken) == said


def test_every_recall_sentence_says_in_for_rooms_and_at_for_points() -> None:
    names = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS).spoken
    pose = {"found": True, "time": "2026-09-21T15:00:00.000Z", "place": "meeting_room"}
    at_three = read_recall("where were you at 3 pm")
    assert recollection(at_three, POSE_AT, json.dumps(pose), False, names) == (
        "At 3pm (15:00:00 UTC) I was in the meeting room Harbour."
    )
    pose["place"] = "dock"
    assert recollection(at_three, POSE_AT, json.dumps(pose), False, names).endswith(
        "I was at the charging dock."
    )
    digest = {"start": {"ago": "1 h ago"}, "items": [
        {"kind": "visit", "place": "reception"},
        {"kind": "sighting", "label": "parcel", "place": "mailroom", "ago": "5 min ago"},
        {"kind": "sighting", "label": "laptop", "place": "desk_alice", "ago": "4 min ago"},
    ]}  # fmt: skip
    said = recollection(read_recall("what happened in the last hour"), WHAT_HAPPENED,
                        json.dumps(digest), False, names)  # fmt: skip
    assert said == (
        "In the last hour: I was at the reception desk; I saw the parcel in the mailroom and "
        "the laptop at Alice's desk."
    )


def test_a_description_that_names_something_else_is_not_used() -> None:
    listed = {"locations": [
        {"name": "lab_3", "description": "Robots are tested here."},
        {"name": "store", "description": "Store room of the facilities team, in the basement"},
        {"name": "nook", "description": ""},
    ]}  # fmt: skip
    places = PlaceIndex.from_result(json.dumps(listed))
    assert [places.spoken(n) for n in ("lab_3", "store", "nook")] == [
        "the lab 3",
        "the store room",
        "the nook",
    ]


async def test_the_chat_says_places_by_their_human_names(understanding: Understanding) -> None:
    chat, messages = RulesChat(understanding), []
    response = await recall_turn(chat, messages, "where did you see the laptop?")
    [call] = response.tool_calls
    found = {"query": "laptop", "found": True, "results": [{
        "label": "laptop", "place": "desk_alice", "last_seen": {
            "ago": "3 min ago", "time": "2026-09-21T14:27:20.000Z"}}]}  # fmt: skip
    messages += [
        response.as_message(),
        Message(role="user", tool_results=[ToolResult(tool_call_id=call.id,
                                                      content=json.dumps(found))]),
    ]  # fmt: skip
    reply = await chat.chat(messages, RECALL_TOOLS)
    assert reply.text == "I last saw the laptop at Alice's desk 3 min ago (14:27:20 UTC)."
