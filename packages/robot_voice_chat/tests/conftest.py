"""Shared fixtures. Real model calls are impossible here: keys are unset and every outbound
socket connection to a non-loopback address is refused."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from typing import Any

import pytest

from robot_voice_chat.robot_words import check_robot_words, witnessing

_REAL_CONNECT = socket.socket.connect
_REAL_CONNECT_EX = socket.socket.connect_ex


def _loopback_only(address: Any) -> None:
    if isinstance(address, tuple) and address:
        host = str(address[0])
        if host not in ("127.0.0.1", "::1", "localhost") and not host.startswith("127."):
            raise ConnectionRefusedError(f"tests may not leave loopback (tried {host})")


MCP_TOKEN_VARS = (
    "NAVIGATION_MCP_TOKEN",
    "MANIPULATION_MCP_TOKEN",
    "MEMORY_MCP_TOKEN",
    "EPISODIC_MCP_TOKEN",
    "SKILL_CONTROL_MCP_TOKEN",
    "PERCEPTION_MCP_TOKEN",
)


@pytest.fixture
def mcp_credentials(monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """Every server's credential in the environment, as install.sh writes brain.env (the
    robot preset refuses to start without them)."""
    tokens = {name: f"{name.lower()}-credential-of-32-bytes-or-more" for name in MCP_TOKEN_VARS}
    for name, value in tokens.items():
        monkeypatch.setenv(name, value)
    return tokens


@pytest.fixture(autouse=True)
def robot_words_are_plain(request: pytest.FixtureRequest) -> Iterator[None]:
    """Everything a test made the robot say or show (through the fake speech and emitter) is
    checked for task ids, tool names, codes, snake_case ids and raw server text (issue 31).
    A test whose scripted planner says such things on purpose is marked
    ``robot_words_unchecked``."""
    if request.node.get_closest_marker("robot_words_unchecked") is not None:
        yield
        return
    with witnessing() as said:
        yield
    found = check_robot_words(said)
    if found:
        pytest.fail("the robot's words leak: " + "; ".join(str(leak) for leak in found[:5]))


@pytest.fixture(autouse=True)
def brain_state_in_tmp(monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> None:
    """The brain's data dir (mission archive, traces) is per test, never the user's."""
    monkeypatch.setenv("RVC_DATA_DIR", str(tmp_path / "rvc-data"))


@pytest.fixture(autouse=True)
def no_real_model_calls(monkeypatch: pytest.MonkeyPatch) -> None:
    for key in ("ANTHROPIC_API_KEY", "OPENAI_API_KEY", "GROQ_API_KEY", "OPENAI_BASE_URL"):
        monkeypatch.delenv(key, raising=False)

    def connect(self: socket.socket, address: Any) -> None:
        _loopback_only(address)
        _REAL_CONNECT(self, address)

    def connect_ex(self: socket.socket, address: Any) -> int:
        _loopback_only(address)
        return _REAL_CONNECT_EX(self, address)

    monkeypatch.setattr(socket.socket, "connect", connect)
    monkeypatch.setattr(socket.socket, "connect_ex", connect_ex)
