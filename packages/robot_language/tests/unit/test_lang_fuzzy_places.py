"""Places as people say them (issue 32): a place spelled a little wrong is matched with
rapidfuzz, asked about when unsure, never matched from a word near nothing; the dock as home or
base; escort, "I need you in X", "send the robot to X", the robot in the third person."""

from __future__ import annotations

import pytest

from robot_language import fuzzy
from robot_language.intents import load_intents
from robot_language.places import PlaceIndex
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding


@pytest.fixture(scope="module")
def places() -> PlaceIndex:
    return PlaceIndex.from_result(OFFICE_LIST_LOCATIONS, load_intents().place_words)


@pytest.mark.parametrize(
    ("said", "name"),
    [("kichen", "kitchen"), ("the mial room", "mailroom"), ("metting room", "meeting_room"),
     ("reciption", "reception"), ("mailrom", "mailroom"), ("bobs desk", "desk_bob")],
)  # fmt: skip
def test_a_place_spelled_a_little_wrong_is_the_place(
    places: PlaceIndex, said: str, name: str
) -> None:
    match = places.resolve(said)
    assert match.sure
    assert match.near
    assert match.names == [name]


@pytest.mark.parametrize(
    "said", ["carols desk", "dave desk", "gym", "garage", "rooftop", "cafeteria on the roof"]
)
def test_a_word_near_no_place_matches_nothing(places: PlaceIndex, said: str) -> None:
    assert places.resolve(said).names == []


def test_a_far_spelling_is_only_a_guess(places: PlaceIndex) -> None:
    match = places.resolve("kitchenette")
    assert match.names == ["kitchen"]
    assert not match.sure


def test_the_fuzzy_wrapper_is_sure_only_when_clear_of_the_runner_up() -> None:
    assert fuzzy.clear(fuzzy.nearest("kichen", ["kitchen", "kitchens"])) is False
    assert fuzzy.clear(fuzzy.nearest("kichen", ["kitchen", "mailroom"])) is True
    assert fuzzy.nearest("gym", ["gym"]) == []  # too short to guess at


def test_an_unsure_place_is_asked_as_did_you_mean_and_yes_goes_there(
    understanding: Understanding, places: PlaceIndex
) -> None:
    reading = understanding.understand("go to the kitchenette", places)
    assert reading.kind == "ask"
    assert reading.question is not None
    assert reading.question.text == "Did you mean the kitchen? (yes or no)"
    answer = understanding.follow_up(reading.question, "yes", places)
    assert answer is not None
    assert answer.code() == ["goto:kitchen"]


def test_ruled_out_places_leave_a_question_about_the_rest(
    understanding: Understanding, places: PlaceIndex
) -> None:
    reading = understanding.understand("go to the desk but not bobs or alices", places)
    assert reading.question is not None
    assert reading.question.text == "Did you mean the reception desk? (yes or no)"


@pytest.mark.parametrize(
    ("said", "codes"),
    [
        ("go to the kichen", ["goto:kitchen"]),
        ("head home", ["goto:dock"]),
        ("return to base", ["goto:dock"]),
        ("go back to your dock", ["goto:dock"]),
        ("take me to alices desk", ["goto:desk_alice"]),
        ("I need you in the mailroom", ["goto:mailroom"]),
        ("send the robot to reception", ["goto:reception"]),
        ("the robot should go to the mailroom", ["goto:mailroom"]),
        ("can the robot go to the dock", ["goto:dock"]),
        ("have the robot drive to alices desk", ["goto:desk_alice"]),
        ("come to the kitchen", ["goto:kitchen"]),
        ("go to the garden", ["refuse"]),
    ],
)
def test_places_and_requests_as_people_say_them(
    understanding: Understanding, places: PlaceIndex, said: str, codes: list[str]
) -> None:
    assert understanding.understand(said, places).code() == codes


def test_home_is_a_site_word_in_the_intents_data_not_in_code() -> None:
    words = load_intents().place_words
    assert words["home"] == ["dock", "charg"]
    assert words["base"] == ["dock", "charg"]
