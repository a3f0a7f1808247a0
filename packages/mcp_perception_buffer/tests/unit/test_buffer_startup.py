"""A configuration the server cannot start with: exit code 2 and one line, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_stack_testing import start_refusal


@pytest.mark.parametrize(
    ("env", "says"),
    [
        ({"MCP_TRANSPORT": "pigeon"}, "MCP_TRANSPORT"),
        ({"PERCEPTION_BUFFER_MAX_COUNT": "lots"}, "max_count"),
        ({"RVC_EVENTS_URL": "http://127.0.0.1:1/api/agent/events"}, "RVC_EVENT_SECRET"),
    ],
)
def test_a_bad_setting_exits_2_with_one_line(
    tmp_path: Path, env: dict[str, str], says: str
) -> None:
    line = start_refusal("mcp_perception_buffer", tmp_path, env)
    assert line.startswith("mcp-perception-buffer: cannot start: ")
    assert says in line
