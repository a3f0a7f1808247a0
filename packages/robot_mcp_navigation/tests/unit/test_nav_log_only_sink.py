from structlog.testing import capture_logs

from robot_mcp_navigation.events.log_only import LogOnlyEventSink


async def test_without_a_secret_the_sink_warns_once_and_logs_events_instead_of_posting() -> None:
    sink = LogOnlyEventSink()

    with capture_logs() as logs:
        await sink.start()
        await sink.emit("nav-1", "navigate_to", "progress", {"pct": 10.0})
        await sink.close()

    assert [entry["event"] for entry in logs] == ["event_secret_missing", "event_not_posted"]
    assert logs[0]["log_level"] == "warning"
    assert "RVC_EVENT_SECRET" in logs[0]["detail"]
    assert logs[1]["task_id"] == "nav-1"
    assert logs[1]["payload"] == {"pct": 10.0}
