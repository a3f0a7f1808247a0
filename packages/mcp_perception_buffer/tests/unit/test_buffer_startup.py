"""A configuration the server cannot start with: exit code 2 and one line, no traceback."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


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
    done = subprocess.run(
        [sys.executable, "-m", "mcp_perception_buffer"],
        env={"PATH": os.environ["PATH"], "HOME": str(tmp_path), **env},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    assert done.stderr.count("\n") == 1
    assert done.stderr.startswith("mcp-perception-buffer: cannot start: ")
    assert says in done.stderr
