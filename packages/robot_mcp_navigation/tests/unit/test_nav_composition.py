from pathlib import Path

import pytest

from robot_mcp_kit.task_events import LogOnlyEventSink, PosterEventSink
from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_navigation import server
from robot_mcp_navigation.composition import build_app
from robot_mcp_navigation.config import load_settings
from robot_mcp_navigation.motion.simulated import SimulatedBase
from robot_stack_testing import async_wait_until

CLOSED_DOOR_MAP = Path(__file__).parents[1] / "maps" / "office_closed_door.yaml"
"""The office places with a scripted closed mailroom door (the in-process simulated base)."""


def test_without_a_secret_events_are_only_logged() -> None:
    app = build_app(load_settings({}))

    assert isinstance(app.events, LogOnlyEventSink)
    assert isinstance(app.base, SimulatedBase)
    assert app.server.name == "navigation"


def test_with_a_secret_events_are_posted_through_the_outbox(tmp_path: Path) -> None:
    outbox = tmp_path / "var" / "outbox.sqlite3"

    app = build_app(load_settings({"RVC_EVENT_SECRET": "k", "NAV_OUTBOX": str(outbox)}))

    assert isinstance(app.events, PosterEventSink)
    assert outbox.parent.is_dir()


def test_failures_can_be_switched_off() -> None:
    door = str(CLOSED_DOOR_MAP)
    assert build_app(load_settings({"NAV_MAP": door})).nav_map.failures
    assert build_app(load_settings({"NAV_MAP": door, "NAV_FAILURES": "0"})).nav_map.failures == []


def test_the_shipped_office_map_scripts_no_failure() -> None:
    assert build_app(load_settings({})).nav_map.failures == []


async def test_the_mailroom_door_is_closed_once_then_the_robot_gets_in() -> None:
    events = FakeEventSink()
    settings = {
        "NAV_TIME_SCALE": "400",
        "NAV_TICK_S": "0.005",
        "NAV_MAP": str(CLOSED_DOOR_MAP),
        "NAV_SUPERVISION": "off",
    }
    app = build_app(load_settings(settings), events=events)

    async with app.running():
        assert events.started
        first = await app.navigator.navigate_to("mailroom")
        await async_wait_until(
            lambda: app.navigator.get_task(first.task_id).state != "running", 10, "first drive"
        )
        failed = events.events[-1]
        second = await app.navigator.navigate_to("mailroom")
        await async_wait_until(
            lambda: app.navigator.get_task(second.task_id).state != "running", 10, "second drive"
        )

    assert events.closed
    assert failed.type == "task_failed"
    assert failed.payload["error_code"] == "DOOR_CLOSED"
    assert any("corridor_b" in s for s in failed.payload["suggestions"])
    assert app.navigator.get_task(second.task_id).state == "succeeded"
    assert app.navigator.pose()["at_location"] == "mailroom"


def test_the_process_refuses_to_start_on_a_missing_map(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("NAV_MAP", str(tmp_path / "missing.yaml"))

    with pytest.raises(SystemExit) as exited:
        server.main()

    assert exited.value.code == 2


def test_the_process_refuses_to_start_on_a_bad_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NAV_TIME_SCALE", "-3")

    with pytest.raises(SystemExit) as exited:
        server.main()

    assert exited.value.code == 2


def test_over_http_the_process_refuses_to_start_without_its_credential(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """No navigation server runs open (issue 27): sse without MCP_AUTH_TOKEN is exit 2, before
    anything drives."""
    monkeypatch.setenv("MCP_TRANSPORT", "sse")
    monkeypatch.delenv("MCP_AUTH_TOKEN", raising=False)
    monkeypatch.delenv("MCP_AUTH", raising=False)
    monkeypatch.setenv("NAV_OUTBOX", str(tmp_path / "outbox.sqlite3"))

    with pytest.raises(SystemExit) as exited:
        server.main()

    assert exited.value.code == 2
    assert not (tmp_path / "outbox.sqlite3").exists()  # refused before the app was built
