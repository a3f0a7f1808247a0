"""The ROLES stage (issue 38 item 1): a carrying request read from its verb and prepositions, in
either order, never a drive that drops the thing. Sentences written from the principle (none is
from a phrasing set). Before the stage 7 of the 8 carrying requests below were asked about,
refused or garbled, and two of the asked ones were driven to wrongly (marked)."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language.config_file import PhrasingsError
from robot_language.roles import DEFAULT_ROLES, read_roles, role_words
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding

PLACES = {"kitchen", "mailroom", "reception", "the dock", "bob's desk"}


def _codes(understanding: Understanding, text: str) -> list[str]:
    return understanding.understand(text, understanding.places(OFFICE_LIST_LOCATIONS)).code()


@pytest.mark.parametrize(
    ("said", "read"),
    [
        (
            "move the green folder from the mailroom to the kitchen",
            "fetch:green folder@mailroom>kitchen",
        ),
        (
            "shift the package from the mailroom over to reception",
            "fetch:package@mailroom>reception",
        ),
        ("relocate the stapler from the kitchen to the dock", "fetch:stapler@kitchen>dock"),
        ("take the red mug to the kitchen from the mailroom", "fetch:red mug@mailroom>kitchen"),
        ("carry the box off the reception desk over to the dock", "fetch:box@reception>dock"),
        ("haul the box out of the mailroom into the kitchen", "fetch:box@mailroom>kitchen"),
        (
            "bring the scissors from the kitchen back to bob's desk",
            "fetch:scissors@kitchen>desk_bob",
        ),
        ("bring the box from the mailroom to me", "fetch:box@mailroom"),
    ],
)
def test_a_carrying_request_is_read_in_any_order(
    understanding: Understanding, said: str, read: str
) -> None:
    assert _codes(understanding, said) == [read]


@pytest.mark.parametrize(
    "said",
    [
        "move the stapler to the meeting room",  # was: a drive there, the stapler dropped
        "take the red mug to the kitchen",  # was: a garbled "where from?"
        "move the green folder from the desk to the kitchen",  # which desk? was: a drive
    ],
)
def test_a_carrying_request_with_a_missing_or_unclear_place_is_asked(
    understanding: Understanding, said: str
) -> None:
    reading = understanding.understand(said, understanding.places(OFFICE_LIST_LOCATIONS))
    assert reading.code() == ["ask"]
    assert reading.question is not None
    assert " to the kitchen from" not in reading.question.text


@pytest.mark.parametrize(
    ("said", "read"),
    [
        ("take a trip to the kitchen", "goto:kitchen"),
        ("take me to the kitchen", "goto:kitchen"),
        ("move to the mailroom", "goto:mailroom"),
        ("move over to reception", "goto:reception"),
        ("get yourself to the kitchen", "goto:kitchen"),
    ],
)
def test_a_drive_said_with_a_carrying_verb_stays_a_drive(
    understanding: Understanding, said: str, read: str
) -> None:
    assert _codes(understanding, said) == [read]


def test_roles_need_a_thing_and_places() -> None:
    words = role_words()

    def place(phrase: str) -> bool:
        return phrase.removeprefix("the ") in PLACES

    assert read_roles("move the box from the kitchen to the mailroom", words, place) is not None
    assert read_roles("move it from the kitchen to the mailroom", words, place) is None
    assert read_roles("move the kitchen to the mailroom", words, place) is None
    assert read_roles("move the box from the garden to the mailroom", words, place) is None
    assert read_roles("move the box to the kitchen to the mailroom", words, place) is None
    assert read_roles("paint the box from the kitchen", words, place) is None
    assert read_roles("move the box", words, place) is None


def test_a_site_adds_a_preposition_without_code(tmp_path: Path) -> None:
    site = tmp_path / "roles.yaml"
    site.write_text(
        DEFAULT_ROLES.read_text(encoding="utf-8").replace(
            "source: [from,", "source: [away from, from,"
        ),
        encoding="utf-8",
    )
    said = "move the box away from the kitchen to the mailroom"
    shipped = read_roles(said, role_words(), lambda p: p.removeprefix("the ") in PLACES)
    assert shipped is not None
    assert shipped.thing == "box away"  # "away from" is not known
    roles = read_roles(said, role_words(site), lambda p: p.removeprefix("the ") in PLACES)
    assert roles is not None
    assert (roles.thing, roles.source, roles.destination) == ("box", "the kitchen", "the mailroom")


def test_a_broken_roles_file_names_its_line(tmp_path: Path) -> None:
    site = tmp_path / "roles.yaml"
    site.write_text("carry_verbs: [move]\nsource: [from]\ndestination: to\n", encoding="utf-8")
    with pytest.raises(PhrasingsError, match=rf"{site}:3: destination"):
        role_words(site)


@pytest.mark.parametrize(
    ("said", "read"),
    [
        # before: "I didn't understand ..." for each
        ("if the package is at reception bring it to the kitchen",
         "fetch:package@reception>kitchen"),
        ("if the red mug is in the kitchen, take it to the dock", "fetch:red mug@kitchen>dock"),
        ("when the box is in the mailroom then carry it over to bob's desk",
         "fetch:box@mailroom>desk_bob"),
        ("the package from the mailroom brought to reception", "fetch:package@mailroom>reception"),
        ("reception's package brought to the kitchen", "fetch:package@reception>kitchen"),
        ("take the mailroom's box over to bob's desk", "fetch:box@mailroom>desk_bob"),
        ("grab reception's package", "fetch:package@reception"),
    ],
)  # fmt: skip
def test_conditions_possessives_and_the_verb_after_the_thing(
    understanding: Understanding, said: str, read: str
) -> None:
    assert _codes(understanding, said) == [read]


def test_a_persons_thing_is_not_read_as_from_their_place(understanding: Understanding) -> None:
    reading = understanding.understand(
        "bring bob's mug to the kitchen", understanding.places(OFFICE_LIST_LOCATIONS)
    )
    assert reading.code() == ["ask"]
    assert reading.question is not None
    assert reading.question.text.startswith("Where should I get bob's mug from?")


@pytest.mark.parametrize(
    "said",
    [
        "the meeting was moved from the kitchen to reception",
        "the package got taken from the mailroom to reception yesterday",
        "the red mug was brought back to the kitchen from the dock",
    ],
)
def test_a_statement_in_the_passive_is_never_a_request(
    understanding: Understanding, said: str
) -> None:
    codes = _codes(understanding, said)
    assert not any(code.startswith("fetch") for code in codes), codes


def test_a_passive_asked_for_is_a_request(understanding: Understanding) -> None:
    said = "i'd like the package from the mailroom brought to reception"
    assert _codes(understanding, said) == ["fetch:package@mailroom>reception"]
