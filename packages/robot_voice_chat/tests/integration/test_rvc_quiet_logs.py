"""Quiet logs (issue 31): a lost MCP server is one structured line (its reason included), and
a normal stop of the brain is no traceback. Real processes: the brain and an MCP server over
SSE; the server is killed with SIGKILL, the brain stopped with SIGINT, then its output read."""

from __future__ import annotations

import json
import os
import signal
import sys
from pathlib import Path

from robot_stack_testing import ProcessLauncher, free_tcp_port, wait_for_tcp_port, wait_until

SERVERS = Path(__file__).with_name("rvc_fake_mcp_servers.py")


def events(log: str) -> list[dict[str, object]]:
    lines = [line for line in log.splitlines() if line.startswith("{")]
    return [json.loads(line) for line in lines]


def test_a_lost_server_and_a_normal_stop_log_one_line_each_and_no_traceback(
    launcher: ProcessLauncher, tmp_path: Path
) -> None:
    server_port, brain_port, dead = free_tcp_port(), free_tcp_port(), free_tcp_port()
    memory = launcher.start(
        "memory", [sys.executable, str(SERVERS), "memory", str(server_port), "sse"]
    )
    wait_for_tcp_port(server_port, 30.0)
    env = {
        "RVC_DATA_DIR": str(tmp_path / "brain"),
        "RVC_MEMORY_URL": f"http://127.0.0.1:{server_port}/sse",
        "RVC_CONFIG_OVERRIDES": "tools.health_interval_s=0.5 tools.connect_timeout_s=2",
        **{
            f"RVC_{name}_URL": f"http://127.0.0.1:{dead}/sse"
            for name in ("NAVIGATION", "EPISODIC", "SKILL_CONTROL", "PERCEPTION")
        },
    }
    brain = launcher.start(
        "brain", [sys.executable, "-m", "robot_voice_chat", "--port", str(brain_port)], env
    )
    wait_until(
        lambda: any(e["event"] == "mcp_server_connected" for e in events(brain.log())),
        60.0,
        "the brain connected to memory",
    )
    os.kill(memory.pid, signal.SIGKILL)
    memory.popen.wait(timeout=10)
    wait_until(
        lambda: any(e["event"] == "mcp_server_disconnected" for e in events(brain.log())),
        30.0,
        "the loss noticed",
    )
    brain.popen.send_signal(signal.SIGTERM)  # as systemd stops it
    assert brain.popen.wait(timeout=30) in (0, -signal.SIGTERM)  # uvicorn re-raises it
    log = brain.log()
    assert "Traceback" not in log, log[-3000:]
    assert "Error in sse_reader" not in log
    lost = [e for e in events(log) if e["event"] == "mcp_server_disconnected"]
    assert len(lost) == 1, lost
    assert lost[0]["server"] == "memory"
    assert "error" in lost[0]  # why, in the same line
    assert "HTTP Request:" not in log  # no line per health check
