"""Every deployment preset boots exactly as shipped through the real entry point, given its
keys (dummies: nothing leaves loopback); a missing key, secret or dependency is a refusal with
exit code 2 and one line, never a traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from robot_stack_testing import wait_until
from robot_stack_testing.ports import free_tcp_port
from robot_voice_chat.api.auth import hash_password

KEYS = {
    "ANTHROPIC_API_KEY": "dummy-anthropic-key",
    "GROQ_API_KEY": "dummy-groq-key",
    "OPENAI_API_KEY": "dummy-openai-key",
    "NAV_EVENT_SECRET": "dummy-navigation-event-secret-of-32-bytes",
    "PERCEPTION_EVENT_SECRET": "dummy-perception-event-secret-of-32-bytes",
    "MANIP_EVENT_SECRET": "dummy-manipulation-event-secret-of-32-bytes",
    "ADMIN_PASSWORD_HASH": hash_password("dummy operator password"),
    "ADMIN_SECRET_KEY": "dummy-session-signing-key-of-32-bytes",
    # each MCP server's credential (install.sh writes them into brain.env)
    **{
        f"{server}_MCP_TOKEN": f"dummy-{server.lower()}-mcp-credential-of-32-bytes"
        for server in (
            "NAVIGATION",
            "MANIPULATION",
            "MEMORY",
            "EPISODIC",
            "SKILL_CONTROL",
            "PERCEPTION",
        )
    },
}
PLANNERS = {
    "dev": "rules",
    "robot": "chain[anthropic,rules]",
    "test": "replay",
    "local_llm": "chain[openai_compat,rules]",
}


def base_env(tmp_path: Path, deployment: str) -> dict[str, str]:
    closed = f"http://127.0.0.1:{free_tcp_port()}/sse"  # no server: the brain keeps retrying
    env = {k: v for k, v in os.environ.items() if k not in KEYS and not k.startswith("RVC_")}
    env.update(
        RVC_DEPLOYMENT=deployment,
        RVC_TRACE_DIR=str(tmp_path / "missions"),
        RVC_NAVIGATION_URL=closed,
        RVC_MANIPULATION_URL=closed,
        RVC_MEMORY_URL=closed,
        RVC_SKILL_CONTROL_URL=closed,
        RVC_PERCEPTION_URL=closed,
        OPENAI_BASE_URL="http://127.0.0.1:9/v1",
    )
    return env


@pytest.fixture
def brain() -> Iterator[list[subprocess.Popen[str]]]:
    started: list[subprocess.Popen[str]] = []
    yield started
    for process in started:
        if process.poll() is None:
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(5)
        if process.stderr is not None:
            process.stderr.close()


def run_refused(env: dict[str, str]) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "robot_voice_chat", "--port", str(free_tcp_port())],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    output = (done.stdout + done.stderr).strip()
    assert done.returncode == 2, output
    assert "Traceback" not in output
    lines = output.splitlines()
    assert len(lines) == 1, output
    return json.loads(lines[0])["error"]  # type: ignore[no-any-return]


@pytest.mark.parametrize("deployment", ["dev", "robot", "test", "local_llm"])
def test_each_preset_boots_as_shipped_and_reports_ready(
    deployment: str, tmp_path: Path, brain: list[subprocess.Popen[str]]
) -> None:
    port = free_tcp_port()
    env = {**base_env(tmp_path, deployment), **KEYS}
    if deployment != "robot":  # login off: a configured password would refuse the start
        del env["ADMIN_PASSWORD_HASH"], env["ADMIN_SECRET_KEY"]
    process = subprocess.Popen(
        [sys.executable, "-m", "robot_voice_chat", "--port", str(port)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    brain.append(process)
    ready: dict[str, object] = {}

    def answers() -> bool:
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        try:
            ready.update(httpx.get(f"http://127.0.0.1:{port}/api/readyz", timeout=2).json())
        except httpx.HTTPError:
            return False
        return True

    wait_until(answers, 60, f"{deployment} preset serving /api/readyz")
    data = ready["data"]
    assert isinstance(data, dict)
    assert data["deployment"] == deployment
    assert data["missions_enabled"] is True
    assert data["planner"] == PLANNERS[deployment]
    if deployment == "local_llm":  # no key, nothing listening: boots, names its fallback
        assert data["planner_understanding"] == (
            "openai_compat (qwen2.5:7b-instruct), fallback rules + embedded matcher"
        )
    assert set(data["mcp_servers"]) == {
        "navigation", "manipulation", "memory", "episodic", "skill_control", "perception",
    }  # fmt: skip
    process.terminate()
    assert process.wait(15) in (0, -15)


def test_robot_without_an_anthropic_key_refuses_to_start(tmp_path: Path) -> None:
    env = {**base_env(tmp_path, "robot"), **KEYS}
    del env["ANTHROPIC_API_KEY"]
    assert "ANTHROPIC_API_KEY is empty" in run_refused(env)


def test_robot_without_event_secrets_refuses_to_start(tmp_path: Path) -> None:
    env = {**base_env(tmp_path, "robot"), **KEYS}
    del env["NAV_EVENT_SECRET"]
    error = run_refused(env)
    assert "servers without an event secret: navigation" in error


def test_robot_without_espeak_ng_refuses_and_names_what_to_install(tmp_path: Path) -> None:
    env = {**base_env(tmp_path, "robot"), **KEYS, "PATH": str(tmp_path)}  # no espeak-ng
    error = run_refused(env)
    assert "espeak-ng" in error
    assert "apt install espeak-ng" in error


def test_an_adapter_whose_package_is_missing_refuses_and_names_the_package(
    tmp_path: Path,
) -> None:
    (tmp_path / "vendor_adapter.py").write_text(
        "import vendor_sdk_not_installed\n\nclass VendorLLM:\n    pass\n"
    )
    env = {
        **base_env(tmp_path, "dev"),
        "PYTHONPATH": str(tmp_path),
        "RVC_CONFIG_OVERRIDES": "llm._target_=vendor_adapter.VendorLLM",
    }
    error = run_refused(env)
    assert "'vendor_sdk_not_installed' is not installed" in error


def test_config_overrides_from_the_environment_reach_the_composition(tmp_path: Path) -> None:
    env = {**base_env(tmp_path, "dev"), "RVC_CONFIG_OVERRIDES": "agent.max_llm_steps=0"}
    assert "max_llm_steps" in run_refused(env)


def test_a_refused_secret_never_appears_in_any_log_line(tmp_path: Path) -> None:
    short = "short-but-secret-value-42"  # refused: fewer than 32 bytes
    env = {**base_env(tmp_path, "robot"), **KEYS, "NAV_EVENT_SECRET": short}
    done = subprocess.run(
        [sys.executable, "-m", "robot_voice_chat", "--port", str(free_tcp_port())],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 2, output
    assert "tools.servers.0.event_secret" in output  # the refusal still says what is wrong
    assert "at least 32" in output
    assert short not in output
    assert "input_value" not in output


@pytest.mark.parametrize("deployment", ["dev", "test"])
def test_a_preset_without_login_refuses_a_configured_password(
    deployment: str, tmp_path: Path
) -> None:
    env = {**base_env(tmp_path, deployment), "ADMIN_PASSWORD_HASH": KEYS["ADMIN_PASSWORD_HASH"]}
    error = run_refused(env)
    assert "ADMIN_PASSWORD_HASH is set but operator login is off" in error
    assert KEYS["ADMIN_PASSWORD_HASH"] not in error
