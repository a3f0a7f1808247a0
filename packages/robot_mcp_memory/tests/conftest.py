"""Sample process documents shared by the memory tests."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from robot_mcp_memory.documents import render_process
from robot_mcp_memory.store.base import ProcessStore, Visibility
from robot_mcp_memory.store.postgres import PostgresProcessStore
from robot_mcp_memory.store.sqlite_fts import SqliteFtsProcessStore

MAILROOM = render_process(
    "fetch-package-from-mailroom",
    "Fetch a package from the mailroom",
    "bring a package from the mailroom to the person who asked for it",
    ["mailroom", "package", "fetch"],
    [
        "navigate_to(mailroom) with trigger eta_below 10",
        "register a reaction: on eta_below prewarm perception find_object(package)",
        "find_object(package) and confirm the name on the label",
        "navigate_to(requester) and say that the package has arrived",
    ],
    ["The mailroom door was closed (DOOR_CLOSED): asked reception to open it, then retried"],
    ["Packages for Anna go to desk 4"],
)
RECEPTION = render_process(
    "collect-parcel-at-reception",
    "Collect a parcel at reception",
    "pick up a parcel or package that was left at the front desk and bring it to its owner",
    ["reception", "parcel", "package"],
    ["navigate_to(reception)", "ask the receptionist for the parcel", "bring it to the owner"],
)
PLANTS = render_process(
    "water-office-plants",
    "Water the office plants",
    "water every plant on the office floor",
    ["plants", "watering"],
    ["fill the watering can in the kitchen", "visit each plant and water it"],
)
PATROL = render_process(
    "evening-security-patrol",
    "Evening security patrol",
    "patrol the corridors in the evening and report open windows",
    ["patrol", "security"],
    ["navigate_to each checkpoint", "report open windows to the operator"],
)
ESCORT = render_process(
    "escort-visitor-to-meeting-room",
    "Escort a visitor to the meeting room",
    "guide a guest from the lobby to a meeting room",
    ["escort", "visitor"],
    ["greet the visitor in the lobby", "navigate_to(meeting room) slowly", "say goodbye"],
)


@dataclass(frozen=True)
class SampleDocuments:
    mailroom: str = MAILROOM
    reception: str = RECEPTION
    plants: str = PLANTS
    patrol: str = PATROL
    escort: str = ESCORT

    def all(self) -> tuple[str, ...]:
        return (self.mailroom, self.reception, self.plants, self.patrol, self.escort)


@pytest.fixture
def docs() -> SampleDocuments:
    return SampleDocuments()


StoreFactory = Callable[..., ProcessStore]


@pytest.fixture(params=["sqlite", "postgres"])
def store_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def open_store(
    store_kind: str, request: pytest.FixtureRequest, tmp_path: Path
) -> Iterator[StoreFactory]:
    """Opens stores of one kind on one shared database (a SQLite file, or a fresh database on
    the throwaway PostgreSQL): ``open_store(robot_id="robot-1", visibility=None)``; the kind's
    default visibility is used when None. Every store it opened is closed at teardown."""
    opened: list[ProcessStore] = []
    dsn = request.getfixturevalue("postgres_dsn") if store_kind == "postgres" else ""

    def factory(robot_id: str = "robot-1", visibility: Visibility | None = None) -> ProcessStore:
        store: ProcessStore
        if store_kind == "postgres":
            store = PostgresProcessStore(dsn, robot_id, visibility=visibility or "fleet")
        else:
            store = SqliteFtsProcessStore(
                tmp_path / "memory.sqlite3", robot_id, visibility=visibility or "robot"
            )
        opened.append(store)
        return store

    try:
        yield factory
    finally:
        for store in opened:
            store.close()
