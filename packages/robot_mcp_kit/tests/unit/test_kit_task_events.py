"""The task-event sinks every task-running server shares (navigation, manipulation)."""

from pathlib import Path

from pydantic import SecretStr
from structlog.testing import capture_logs

from robot_mcp_kit.task_events import LogOnlyEventSink, PosterEventSink, build_event_sink
from robot_mcp_kit.task_events.fake import FakeEventSink


async def test_without_a_secret_the_sink_warns_once_and_logs_events_instead_of_posting() -> None:
    sink = LogOnlyEventSink("NAV_EVENT_SECRET")

    with capture_logs() as logs:
        await sink.start()
        await sink.emit("nav-1", "navigate_to", "progress", {"pct": 10.0})
        await sink.close()

    assert [entry["event"] for entry in logs] == ["event_secret_missing", "event_not_posted"]
    assert logs[0]["log_level"] == "warning"
    assert "RVC_EVENT_SECRET" in logs[0]["detail"]
    assert "NAV_EVENT_SECRET" in logs[0]["detail"]
    assert logs[1]["task_id"] == "nav-1"
    assert logs[1]["payload"] == {"pct": 10.0}


def test_a_secret_gives_signed_posts_with_an_outbox_and_none_gives_the_log(tmp_path: Path) -> None:
    outbox = tmp_path / "state" / "outbox.sqlite3"
    url = "http://127.0.0.1:9/api/agent/events"
    quiet = build_event_sink("manipulation", url, None, outbox, "MANIP_EVENT_SECRET")
    assert isinstance(quiet, LogOnlyEventSink)
    assert quiet.brain_secret_env == "MANIP_EVENT_SECRET"
    assert not outbox.parent.exists()
    signed = build_event_sink("manipulation", url, SecretStr("s" * 32), outbox, "X")
    assert isinstance(signed, PosterEventSink)
    assert outbox.parent.is_dir()


async def test_the_fake_records_events_in_order_per_task() -> None:
    sink = FakeEventSink()
    await sink.start()
    await sink.emit("t-1", "pick", "progress", {"pct": 50})
    await sink.emit("t-2", "place", "task_done", {})
    await sink.emit("t-1", "pick", "task_done", {})
    await sink.close()
    assert (sink.started, sink.closed) == (True, True)
    assert sink.types("t-1") == ["progress", "task_done"]
