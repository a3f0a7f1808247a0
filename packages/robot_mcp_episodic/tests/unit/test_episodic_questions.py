"""The scripted office day (3 h, time-compressed) and >= 60 questions with known answers, asked
through the MCP tools as the planner would."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import (
    DAY_S,
    Episode,
    ManualClock,
    Question,
    play_office_day,
    questions,
)
from robot_mcp_episodic.store.base import EpisodicStore
from robot_mcp_episodic.store.postgres import PostgresEpisodicStore
from robot_stack_testing.kit.tool_calls import tool_answer

START = 1_790_000_000.0
Day = tuple[EpisodicApp, list[Question]]


def played_day(data_dir: Path, store: EpisodicStore | None = None) -> Day:
    clock = ManualClock(START)
    app = build_app(
        EpisodicConfig(data_dir=data_dir, record_raw=False),
        store=store, record_ros=False, clock=clock,
    )  # fmt: skip
    episode = Episode(app.memory.indexer, app.memory.places, clock)
    shown = play_office_day(episode)
    assert clock.now == START + DAY_S
    return app, questions(START, clock.now, shown)


@pytest.fixture(scope="module", params=["sqlite", "postgres"])
def day(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Day]:
    store: EpisodicStore | None = None
    if request.param == "postgres":
        server = request.getfixturevalue("postgres_server")
        store = PostgresEpisodicStore(server.create_database(), "robot-1")
    app, asked = played_day(tmp_path_factory.mktemp("episodic"), store)
    try:
        yield app, asked
    finally:
        app.close()


SHOWN_KEYS = (
    "charger", "red mug@kitchen", "scissors", "person", "laptop", "coffee machine", "red mug",
    "parcel#1", "parcel",
)  # fmt: skip
QUESTION_COUNT = len(questions(START, START + DAY_S, dict.fromkeys(SHOWN_KEYS, (0.0, 0.0))))


def test_the_question_set_has_at_least_sixty_questions() -> None:
    assert QUESTION_COUNT >= 60


@pytest.mark.parametrize("index", range(QUESTION_COUNT))
async def test_question_is_answered_right_through_the_tools(day: Day, index: int) -> None:
    app, asked = day
    question = asked[index]
    async with Client(app.server) as client:
        answer: dict[str, Any] = await tool_answer(client, question.tool, question.args)
    assert "_error" not in answer, answer
    assert question.check(answer), f"{question.text}: {answer}"
