"""NAV_CONFIRM_MOTION=elicit with the SDK's own client: accept drives, decline and a client
without elicitation are clean refusals and the robot does not move."""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any

import pytest
from mcp import Client
from mcp.client.session import ClientRequestContext
from mcp.types import ElicitRequestParams, ElicitResult, TextContent

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.config import NavigationSettings
from robot_mcp_navigation.confirmation import (
    CONFIRMATION_UNAVAILABLE,
    NOT_CONFIRMED,
    MotionConfirmer,
)
from robot_mcp_navigation.map import NavMap, parse_map
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.tools import build_mcp_server

MAP = {
    "start": "dock",
    "locations": {
        "dock": {"x": 0, "y": 0},
        "kitchen": {"x": 8, "y": 0, "description": "Kitchen with the coffee machine"},
    },
    "speed_mps": 2.0,
}


class Person:
    """The human behind the client: answers each question as told and remembers it."""

    def __init__(self, action: str, confirm: bool = True) -> None:
        self.action = action
        self.confirm = confirm
        self.questions: list[ElicitRequestParams] = []

    async def __call__(
        self, context: ClientRequestContext, params: ElicitRequestParams
    ) -> ElicitResult:
        self.questions.append(params)
        content = {"confirm": self.confirm} if self.action == "accept" else None
        return ElicitResult(action=self.action, content=content)  # type: ignore[arg-type]


@pytest.fixture
async def rig() -> AsyncIterator[tuple[Navigator, FakeMotionBase, Any]]:
    nav_map: NavMap = parse_map(MAP)
    base = FakeMotionBase(speed_mps=2.0)
    navigator = Navigator(nav_map, base, FakeEventSink(), TaskTable())
    yield navigator, base, build_mcp_server(navigator, confirmer=MotionConfirmer(nav_map))
    await navigator.close()


def answer(result: Any) -> tuple[bool, dict[str, Any]]:
    (content,) = result.content
    assert isinstance(content, TextContent)
    text = content.text
    return bool(result.is_error), json.loads(text[text.index("{") :])


async def test_an_accepted_confirmation_starts_the_drive_and_names_the_destination(
    rig: tuple[Navigator, FakeMotionBase, Any],
) -> None:
    navigator, _, server = rig
    person = Person("accept")
    async with Client(server, mode="legacy", elicitation_callback=person) as client:
        is_error, info = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))

    assert not is_error, info
    assert info["state"] == "running"
    (asked,) = person.questions
    assert "kitchen (Kitchen with the coffee machine)" in asked.message
    assert navigator.pose()["moving"] is True


@pytest.mark.parametrize(
    ("action", "confirm"), [("decline", True), ("cancel", True), ("accept", False)]
)
async def test_a_declined_confirmation_is_a_clean_refusal_and_nothing_moves(
    rig: tuple[Navigator, FakeMotionBase, Any], action: str, confirm: bool
) -> None:
    navigator, _, server = rig
    person = Person(action, confirm)
    async with Client(server, mode="legacy", elicitation_callback=person) as client:
        is_error, error = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))

    assert is_error
    assert error["error"] == NOT_CONFIRMED
    assert "did not move" in error["detail"]
    assert navigator.pose()["moving"] is False
    assert navigator.list_tasks() == []


async def test_a_client_without_elicitation_is_refused_with_how_to_enable_motion(
    rig: tuple[Navigator, FakeMotionBase, Any],
) -> None:
    navigator, _, server = rig
    async with Client(server, mode="legacy") as client:  # declares no elicitation capability
        is_error, error = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))

    assert is_error
    assert error["error"] == CONFIRMATION_UNAVAILABLE
    assert "NAV_CONFIRM_MOTION" in error["detail"]
    assert "elicitation" in error["detail"]
    assert navigator.pose()["moving"] is False
    assert navigator.list_tasks() == []


async def test_a_connection_without_a_back_channel_is_refused_never_a_yes(
    rig: tuple[Navigator, FakeMotionBase, Any],
) -> None:
    """In-process dispatch (no JSON-RPC back-channel) cannot carry the question."""
    navigator, _, server = rig
    person = Person("accept")
    async with Client(server, elicitation_callback=person) as client:
        is_error, error = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))
    assert is_error
    assert error["error"] == CONFIRMATION_UNAVAILABLE
    assert navigator.pose()["moving"] is False


async def test_without_the_setting_no_question_is_asked() -> None:
    nav_map = parse_map(MAP)
    navigator = Navigator(nav_map, FakeMotionBase(speed_mps=2.0), FakeEventSink(), TaskTable())
    person = Person("decline")
    async with Client(build_mcp_server(navigator), elicitation_callback=person) as client:
        is_error, _ = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))
    await navigator.close()
    assert not is_error
    assert person.questions == []


def test_the_setting_reads_nav_confirm_motion_and_refuses_other_values() -> None:
    assert NavigationSettings.model_validate({"NAV_CONFIRM_MOTION": "elicit"}).confirm_motion == (
        "elicit"
    )
    assert NavigationSettings.model_validate({}).confirm_motion == "off"
    with pytest.raises(ValueError, match=r"NAV_CONFIRM_MOTION|confirm_motion"):
        NavigationSettings.model_validate({"NAV_CONFIRM_MOTION": "yes"})


async def test_a_latched_server_refuses_without_asking_anyone_to_confirm() -> None:
    """Issue 27: a drive supervision refuses is never put to a person first."""
    from robot_mcp_kit.supervision import Supervision

    nav_map: NavMap = parse_map(MAP)
    base = FakeMotionBase(speed_mps=2.0)
    supervision = Supervision(required=False)
    supervision.renew("brain", 1.0, latched=True)
    navigator = Navigator(nav_map, base, FakeEventSink(), TaskTable(), supervision=supervision)
    server = build_mcp_server(navigator, confirmer=MotionConfirmer(nav_map))
    person = Person("accept")

    async with Client(server, elicitation_callback=person) as client:
        result = await client.call_tool("navigate_to", {"location": "kitchen"})

    assert result.is_error
    assert json.loads(result.content[0].text)["error"] == "SAFETY_STOP_LATCHED"  # type: ignore[union-attr]
    assert person.questions == []
    assert base.goals == []
    await navigator.close()
