"""The four MCP servers over stdio, as an MCP host spawns them (issue 13 item 12).

Each server is started from an empty, read-only working directory (mode 0555; the tests also
check nothing was written there, which matters when they run as root) with a throwaway HOME:

* the MCP Inspector CLI (a third-party client from npm, pinned in tools/mcp-inspector and
  installed by ``make setup``) lists its tools;
* a raw session (initialize, tools/list, hang up) proves stdout carries JSON-RPC only from
  start-up to exit. The ROS servers run with ``RCUTILS_LOGGING_USE_STDOUT=1`` and an
  invalid ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (rcl then warns, on stdout, and falls back to
  localhost): that warning must land on stderr.

The memory server is given ``MEMORY_DB`` under the throwaway HOME: where its DB lives by
default is the memory server's own concern (issue 13 item 11, tested in its package).
"""

from __future__ import annotations

import os
import stat
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_stack_testing import inspector_tools_list, non_protocol_lines, stdio_session

BIN = Path(sys.executable).parent
RCL_WARNING = "Invalid value 'LOCALHOST_PLEASE' specified for 'ROS_AUTOMATIC_DISCOVERY_RANGE'"

SERVERS = {
    "skill_control": ("mcp-skill-control", True, "instantiate_skill"),
    "perception": ("mcp-perception-buffer", True, "what_do_you_see"),
    "memory": ("robot-mcp-memory", False, "find_processes"),
    "navigation": ("robot-mcp-navigation", False, "navigate_to"),
    "manipulation": ("robot-mcp-manipulation", True, "pick"),
}


@pytest.fixture
def read_only_cwd(tmp_path: Path) -> Iterator[Path]:
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    cwd.chmod(stat.S_IRUSR | stat.S_IXUSR | stat.S_IRGRP | stat.S_IXGRP | stat.S_IROTH)
    try:
        yield cwd
        assert list(cwd.iterdir()) == [], "the server wrote into its working directory"
    finally:
        cwd.chmod(stat.S_IRWXU)


def server_env(name: str, home: Path, ros_domain_id: int) -> dict[str, str]:
    _, ros, _ = SERVERS[name]
    env = {"HOME": str(home), "MCP_TRANSPORT": "stdio", "LOG_LEVEL": "INFO"}
    if ros:
        env |= {"ROS_DOMAIN_ID": str(ros_domain_id), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    if name == "memory":
        env["MEMORY_DB"] = str(home / "memory.sqlite3")
    return env


@pytest.mark.parametrize("name", sorted(SERVERS))
def test_the_mcp_inspector_lists_each_servers_tools_over_stdio(
    name: str, read_only_cwd: Path, tmp_path: Path, ros_domain_id: int
) -> None:
    script, _, a_tool = SERVERS[name]
    env = server_env(name, tmp_path, ros_domain_id)

    answer = inspector_tools_list([str(BIN / script)], env, read_only_cwd)

    assert a_tool in {tool["name"] for tool in answer["tools"]}


@pytest.mark.parametrize("name", sorted(SERVERS))
def test_each_server_writes_nothing_but_json_rpc_on_stdout(
    name: str, read_only_cwd: Path, tmp_path: Path, ros_domain_id: int
) -> None:
    script, ros, a_tool = SERVERS[name]
    env = {"PATH": os.environ["PATH"], **server_env(name, tmp_path, ros_domain_id)}
    if ros:
        env |= {
            "RCUTILS_LOGGING_USE_STDOUT": "1",
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST_PLEASE",
        }

    transcript = stdio_session([str(BIN / script)], env, read_only_cwd)

    assert non_protocol_lines(transcript) == [], transcript.stderr[-2000:]
    assert transcript.returncode == 0, transcript.stderr[-2000:]
    tools = next(m for m in transcript.messages() if m.get("id") == 2)["result"]["tools"]
    assert a_tool in {tool["name"] for tool in tools}
    if ros:
        assert RCL_WARNING in transcript.stderr  # the native output happened, on stderr
