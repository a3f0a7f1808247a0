"""The normalisation stage (issue 32): speech-to-text output written the way the grammar reads
it, tested on its own, and the requests it makes readable (each failed before it)."""

from __future__ import annotations

import pytest

from robot_language.normalise import normalise, possessors
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding


@pytest.mark.parametrize(
    ("heard", "read"),
    [
        ("uh can you go to the kitchen", "can you go to the kitchen"),
        ("Umm, er, GO TO THE MAILROOM", "go to the mailroom"),
        ("Go. To. The. Meeting. Room.", "go to the meeting room"),
        ("go go to the the kitchen", "go to the kitchen"),
        ("go to go to reception", "go to reception"),
        ("can u go 2 the kitchen pls", "can you go to the kitchen please"),
        ("look 4 my keys", "look for my keys"),
        ("where r u", "where are you"),
        ("thx", "thanks"),
        ("dont go to the kitchen", "don't go to the kitchen"),
        ("whats the time", "what's the time"),
        ("id like you to go", "i'd like you to go"),
        ("go to like the kitchen", "go to the kitchen"),
        ("i like the kitchen", "i like the kitchen"),  # a verb, not a filler
        ("so, well, go to the dock", "go to the dock"),
        ("go to room twenty three", "go to room 23"),
        ("patrol it four times", "patrol it 4 times"),
        ("patrol it two times", "patrol it two times"),  # small numbers stay words
        ("first the kitchen then the second room", "first the kitchen then the second room"),
        ("where were you at 15:30?", "where were you at 15:30?"),
        ("go to the kitchen, um, then reception", "go to the kitchen, then reception"),
    ],
)
def test_speech_is_written_as_the_grammar_reads_it(heard: str, read: str) -> None:
    assert normalise(heard) == read


def test_possessives_get_their_apostrophe_back_only_for_the_maps_people() -> None:
    owners = possessors(["Alice's desk in the open-plan office.", "Bob's desk."])
    assert owners == {"alice", "bob"}
    assert normalise("go to bobs desk", owners) == "go to bob's desk"
    assert normalise("take me to alices desk", owners) == "take me to alice's desk"
    assert normalise("go to carols desk", owners) == "go to carols desk"  # not on the map
    assert normalise("look for the keys", owners) == "look for the keys"


@pytest.mark.parametrize(
    ("heard", "codes"),
    [
        ("uh can you go to the kitchen", ["goto:kitchen"]),
        ("can u go 2 the kitchen", ["goto:kitchen"]),
        ("robot go to bobs desk", ["goto:desk_bob"]),
        ("Go. To. The. Meeting. Room.", ["goto:meeting_room"]),
        ("umm go to reception", ["goto:reception"]),
        ("look 4 the red mug in the kitchen", ["find:red mug@kitchen"]),
    ],
)
def test_speech_style_requests_are_understood(
    understanding: Understanding, heard: str, codes: list[str]
) -> None:
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    assert understanding.understand(heard, places).code() == codes
