"""Where a motion server's task events go (the port) and its adapters: signed posts to the
brain, a log when no secret is set, and a recording fake for tests. Shared by every server
that runs tasks under the Async Task Contract (navigation, manipulation)."""

from robot_mcp_kit.task_events.log_only import LogOnlyEventSink
from robot_mcp_kit.task_events.poster_sink import PosterEventSink, build_event_sink
from robot_mcp_kit.task_events.sink import EventSink

__all__ = ["EventSink", "LogOnlyEventSink", "PosterEventSink", "build_event_sink"]
