"""Config composition and app boot: dev boots clean with no keys and no servers (§14)."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.auth import hash_password
from robot_voice_chat.composition import bootstrap, compose_config
from robot_voice_chat.main import main
from robot_voice_chat.socket_events import json_schemas


async def test_dev_deployment_boots_without_keys_and_reports_servers_disconnected(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path))
    monkeypatch.setenv("RVC_NAVIGATION_URL", "http://127.0.0.1:9/sse")
    config = compose_config("dev")
    assert config.llm["_target_"].endswith("ReplayLLM")
    assert config.tools.servers[0].motion
    assert config.tools.servers[0].safety_stop_tool == "stop_navigation"
    container = bootstrap(config)
    app = create_app(container)
    transport = httpx.ASGITransport(app)
    async with (
        app.router.lifespan_context(app),
        httpx.AsyncClient(transport=transport, base_url="http://t") as c,
    ):
        assert (await c.get("/api/livez")).json() == {"status": "ok"}

        async def navigation_down() -> bool:
            r = await c.get("/api/readyz")
            return bool(r.json()["data"]["mcp_servers"]["navigation"] == "disconnected")

        await async_wait_until(navigation_down, 10, "navigation reported disconnected")
        ready = (await c.get("/api/readyz")).json()
        assert ready["data"]["missions_enabled"] is True
        greeting = (await c.post("/api/chat", json={"text": "hello"})).json()
        assert "recorded" in greeting["reply"]


async def test_robot_deployment_disables_missions_without_an_anthropic_key(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("GROQ_API_KEY", "test")
    monkeypatch.setenv("OPENAI_API_KEY", "test")
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", hash_password("robot operator"))
    monkeypatch.setenv("ADMIN_SECRET_KEY", "k" * 32)
    config = compose_config("robot", ["speech_output=socketio"])
    container = bootstrap(config)
    assert container.adapters.planner is None
    assert not container.executor.enabled
    assert container.adapters.llm.name == "openai_compat"
    assert container.auth is not None  # the robot preset needs an operator login
    await container.stop()


def test_startup_refuses_an_empty_key_for_the_selected_fast_path_adapter(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("RVC_DEPLOYMENT", "robot")
    assert main(["--port", "1"]) == 2


def test_socket_event_schemas_are_exported_for_the_frontend() -> None:
    schemas = json_schemas()
    assert {"mission_plan", "mission_event", "mission_finished", "send_message"} <= set(schemas)
    assert "steps" in schemas["mission_plan"]["properties"]
