"""Stdio: the process's stdout carries JSON-RPC only, even when a native library writes to
fd 1 before, during and after the session (issue 13 item 12)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from robot_stack_testing import non_protocol_lines, stdio_session

PROC = Path(__file__).parent / "procs" / "kit_mcp_server.py"


def env(**extra: str) -> dict[str, str]:
    return {"PATH": os.environ["PATH"], "MCP_TRANSPORT": "stdio", "KIT_PROC_NOISE": "1", **extra}


def test_with_stdout_reserved_native_output_goes_to_stderr(tmp_path: Path) -> None:
    transcript = stdio_session([sys.executable, str(PROC)], env(KIT_PROC_RESERVE="1"), tmp_path)

    assert transcript.returncode == 0, transcript.stderr
    assert non_protocol_lines(transcript) == []
    assert [m.get("id") for m in transcript.messages()] == [1, 2]
    assert "[native] at start-up" in transcript.stderr
    assert "[native] at shutdown" in transcript.stderr


def test_without_the_reservation_the_same_output_pollutes_stdout(tmp_path: Path) -> None:
    """The control: what reserve_stdout prevents (the SDK alone guards only its session)."""
    transcript = stdio_session([sys.executable, str(PROC)], env(), tmp_path)

    assert "[native] at start-up" in non_protocol_lines(transcript)


@pytest.mark.parametrize("reserve", ["1", "0"])
def test_both_ways_the_session_itself_answers(tmp_path: Path, reserve: str) -> None:
    transcript = stdio_session([sys.executable, str(PROC)], env(KIT_PROC_RESERVE=reserve), tmp_path)
    tools = next(m for m in transcript.messages() if m.get("id") == 2)["result"]["tools"]
    assert {t["name"] for t in tools} == {"fail", "echo", "whoami"}
