"""The stdio helpers against tiny stdio MCP servers written here."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from robot_stack_testing import inspector_tools_list, non_protocol_lines, stdio_session

SERVER = """
import os, sys
from mcp.server.mcpserver import MCPServer
if os.environ.get("NOISE"):
    print("hello from a chatty library", flush=True)
server = MCPServer("tiny")

@server.tool()
def ping() -> str:
    \"\"\"Answers pong.\"\"\"
    return "pong"

server.run("stdio")
"""
HANGS = "import time\nprint('not a protocol line', flush=True)\ntime.sleep(60)\n"


def env(**extra: str) -> dict[str, str]:
    return {"PATH": os.environ["PATH"], "HOME": os.environ.get("HOME", "/tmp"), **extra}


def test_a_clean_server_has_only_protocol_lines(tmp_path: Path) -> None:
    transcript = stdio_session([sys.executable, "-c", SERVER], env(), tmp_path)

    assert non_protocol_lines(transcript) == []
    assert [m["id"] for m in transcript.messages()] == [1, 2]
    assert transcript.messages()[1]["result"]["tools"][0]["name"] == "ping"
    assert transcript.returncode == 0


def test_a_chatty_server_is_caught(tmp_path: Path) -> None:
    transcript = stdio_session([sys.executable, "-c", SERVER], env(NOISE="1"), tmp_path)

    assert non_protocol_lines(transcript) == ["hello from a chatty library"]
    assert [m["id"] for m in transcript.messages()] == [1, 2]


def test_a_server_that_never_answers_fails_in_time(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match="no answer to request 1"):
        stdio_session([sys.executable, "-c", HANGS], env(), tmp_path, timeout_s=3.0)


def test_the_inspector_lists_the_tools_of_a_stdio_server(tmp_path: Path) -> None:
    answer = inspector_tools_list([sys.executable, "-c", SERVER], {}, tmp_path)

    assert [tool["name"] for tool in answer["tools"]] == ["ping"]


def test_an_inspector_failure_is_reported_with_its_stderr(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match="the inspector failed"):
        inspector_tools_list([sys.executable, "-c", "raise SystemExit(3)"], {}, tmp_path, 60)
