"""last_seen with a misspelt thing ("scisors"): the one label on record close to it is looked up
and said back (``read_as``), never a false "no record" and never a label the memory does not
hold."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import Episode, ManualClock
from robot_mcp_episodic.matching import corrected_query, matching_labels
from robot_stack_testing.kit.tool_calls import tool_answer

T = 1_790_000_000.0
LABELS = ["charger", "red mug", "coffee machine", "scissors", "person", "laptop", "parcel"]


@pytest.mark.parametrize(
    ("query", "read_as"),
    [("scisors", "scissor"), ("lapotp", "laptop"), ("red mugg", "red mug"),
     ("percel", "parcel"), ("the notebok", None)],
)  # fmt: skip
def test_a_typo_is_read_as_the_one_close_label_word(query: str, read_as: str | None) -> None:
    assert corrected_query(LABELS, query) == read_as


@pytest.mark.parametrize(
    "query", ["giraffe", "umbrella", "printer", "stapler", "keys", "cat", "water bottle", "mug"]
)
def test_no_correction_without_a_close_label_or_when_none_is_needed(query: str) -> None:
    assert corrected_query(LABELS, query) is None


def test_two_equally_close_labels_are_no_correction() -> None:
    assert corrected_query(["cart", "card"], "carx") is None


@pytest.fixture
def app(tmp_path: Path) -> Iterator[EpisodicApp]:
    clock = ManualClock(T)
    built = build_app(
        EpisodicConfig(data_dir=tmp_path, record_raw=False), record_ros=False, clock=clock
    )
    episode = Episode(built.memory.indexer, built.memory.places, clock)
    episode.drive_to("reception")
    episode.look(10, "detect", ["scissors"])
    built.memory.indexer.flush()
    try:
        yield built
    finally:
        built.close()


async def _last_seen(app: EpisodicApp, query: str) -> dict[str, Any]:
    async with Client(app.server) as client:
        answer: dict[str, Any] = await tool_answer(client, "last_seen", {"query": query})
        return answer


async def test_last_seen_finds_a_misspelt_thing_and_says_how_it_read_it(app: EpisodicApp) -> None:
    answer = await _last_seen(app, "scisors")
    assert answer["found"] is True
    assert (answer["read_as"], answer["results"][0]["label"]) == ("scissor", "scissors")
    assert "(I read 'scisors' as scissors.)" in answer["answer"]


async def test_an_exact_query_is_not_read_as_anything(app: EpisodicApp) -> None:
    answer = await _last_seen(app, "scissors")
    assert (answer["found"], answer["read_as"]) == (True, None)


async def test_a_thing_never_seen_stays_no_record(app: EpisodicApp) -> None:
    answer = await _last_seen(app, "stapler")
    assert (answer["found"], answer["read_as"]) == (False, None)
    assert answer["answer"].startswith("I have no record of seeing stapler")


def test_a_package_and_a_parcel_are_the_same_thing_whichever_was_recorded() -> None:
    assert matching_labels(["yellow package", "red mug"], "parcel") == ["yellow package"]
    assert matching_labels(["parcel"], "the package") == ["parcel"]
