"""Config composition and app boot: dev boots clean with no keys and no servers (§14)."""

from __future__ import annotations

import re
from pathlib import Path

import httpx
import pytest
from omegaconf import OmegaConf

from robot_stack_testing import async_wait_until
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.auth import hash_password
from robot_voice_chat.api.routes.health import servers_ready
from robot_voice_chat.composition import ConfigError, bootstrap, compose_config
from robot_voice_chat.main import main
from robot_voice_chat.settings import CONFIG_DIR
from robot_voice_chat.socket_events import json_schemas


async def test_dev_deployment_boots_without_keys_and_reports_servers_disconnected(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path))
    monkeypatch.setenv("RVC_NAVIGATION_URL", "http://127.0.0.1:9/sse")
    config = compose_config("dev")
    assert config.llm["_target_"].endswith("RulesChat")
    assert config.llm_planner is not None
    assert config.llm_planner["_target_"].endswith("RulesPlanner")
    assert config.tools.servers[0].motion
    assert config.tools.servers[0].safety_stop_tool == "stop_navigation"
    container = bootstrap(config)
    app = create_app(container)
    transport = httpx.ASGITransport(app)
    async with (
        app.router.lifespan_context(app),
        httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as c,
    ):
        assert (await c.get("/api/livez")).json() == {"status": "ok"}

        async def navigation_down() -> bool:
            r = await c.get("/api/readyz")
            return bool(r.json()["data"]["mcp_servers"]["navigation"] == "disconnected")

        await async_wait_until(navigation_down, 10, "navigation reported disconnected")
        ready = (await c.get("/api/readyz")).json()
        assert ready["data"]["missions_enabled"] is True
        assert ready["data"]["planner_understanding"] == "rules + embedded matcher"
        assert ready["data"]["llm_understanding"] == "rules + embedded matcher"
        config = (await c.get("/api/ui/config")).json()
        assert config["planner_understanding"] == "rules + embedded matcher"
        greeting = (await c.post("/api/chat", json={"text": "hello"})).json()
        assert "offline voice" in greeting["reply"]


@pytest.mark.usefixtures("mcp_credentials")
def test_episodic_memory_is_configured_in_every_preset_and_optional_for_readiness(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for name in ("NAV_EVENT_SECRET", "PERCEPTION_EVENT_SECRET", "MANIP_EVENT_SECRET"):
        monkeypatch.setenv(name, "an-event-secret-that-is-32-bytes-long")
    monkeypatch.delenv("RVC_EPISODIC_URL", raising=False)
    for deployment in ("dev", "robot", "test"):
        servers = {s.name: s for s in compose_config(deployment).tools.servers}
        assert servers["episodic"].optional, deployment
        assert servers["episodic"].url == "http://127.0.0.1:9203/sse"
        assert not servers["navigation"].optional
        arm = servers["manipulation"]  # issue 28: a motion server the stop and barge-in reach
        assert arm.motion, deployment
        assert arm.safety_stop_tool == "stop_manipulation"
        assert arm.optional  # a robot without an arm still boots ready
        assert arm.url == "http://127.0.0.1:9102/sse"
    states = {"navigation": "connected", "episodic": "disconnected"}
    assert servers_ready(states, {"episodic"})
    assert not servers_ready(states, set())
    assert not servers_ready({**states, "navigation": "disconnected"}, {"episodic"})


def test_the_robot_preset_refuses_http_servers_it_has_no_credential_for(
    monkeypatch: pytest.MonkeyPatch, mcp_credentials: dict[str, str]
) -> None:
    for name in ("NAV_EVENT_SECRET", "PERCEPTION_EVENT_SECRET"):
        monkeypatch.setenv(name, "an-event-secret-that-is-32-bytes-long")
    monkeypatch.delenv("NAVIGATION_MCP_TOKEN")
    monkeypatch.setenv("EPISODIC_MCP_TOKEN", "")
    with pytest.raises(ConfigError) as refused:
        compose_config("robot")
    assert "MCP servers without a credential: navigation, episodic" in str(refused.value)
    assert mcp_credentials["MEMORY_MCP_TOKEN"] not in str(refused.value)
    dev = {s.name: s for s in compose_config("dev").tools.servers}  # dev: the brain may go
    assert dev["navigation"].auth_token is None  # without; the server then answers 401
    assert dev["memory"].auth_token is not None
    monkeypatch.setenv("EPISODIC_MCP_TOKEN", "too-short")
    with pytest.raises(ConfigError, match="auth_token is 9 bytes") as short:
        compose_config("robot")
    assert "too-short" not in str(short.value)


@pytest.mark.usefixtures("mcp_credentials")
def test_robot_deployment_refuses_a_configured_planner_without_its_key(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("GROQ_API_KEY", "test")
    monkeypatch.setenv("OPENAI_API_KEY", "test")
    for name in ("NAV_EVENT_SECRET", "PERCEPTION_EVENT_SECRET", "MANIP_EVENT_SECRET"):
        monkeypatch.setenv(name, "an-event-secret-that-is-32-bytes-long")
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", hash_password("robot operator"))
    monkeypatch.setenv("ADMIN_SECRET_KEY", "k" * 32)
    config = compose_config("robot", ["speech_output=socketio"])
    with pytest.raises(ConfigError, match="ANTHROPIC_API_KEY is empty"):
        bootstrap(config)


def test_a_bad_override_is_one_config_error(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ConfigError, match="configuration"):
        compose_config("dev", ["agent.no_such_key=1"])


def test_startup_refuses_an_empty_key_for_the_selected_fast_path_adapter(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("RVC_DEPLOYMENT", "robot")
    assert main(["--port", "1"]) == 2


def test_socket_event_schemas_are_exported_for_the_frontend() -> None:
    schemas = json_schemas()
    assert {"mission_plan", "mission_event", "mission_finished", "send_message"} <= set(schemas)
    assert "steps" in schemas["mission_plan"]["properties"]


def robot_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """The robot's name and every secret the tool config reads (dummy values)."""
    monkeypatch.setenv("ROBOT_HOSTNAME", "robot-7.lan")
    listed = (CONFIG_DIR / "tools" / "mcp.yaml").read_text(encoding="utf-8")
    for name in re.findall(r"oc\.env:(\w*(?:SECRET|CREDENTIAL|TOKEN)\w*)", listed):
        monkeypatch.setenv(name, "a-dummy-value-that-is-longer-than-32-bytes")


def test_the_robot_preset_trusts_the_robots_own_host_name(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 31: config.yaml's own api block overrode the preset's (``_self_`` came last)."""
    robot_environment(monkeypatch)
    assert "robot-7.lan" in compose_config("robot").api.trusted_hosts
    assert "robot-7.lan" not in compose_config("dev").api.trusted_hosts


def _leaves(tree: object, path: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], object]]:
    if isinstance(tree, dict):
        return [leaf for key, value in tree.items() for leaf in _leaves(value, (*path, key))]
    return [(path, tree)]


@pytest.mark.parametrize("preset", ["dev", "robot", "test", "local_llm"])
def test_every_value_a_deployment_preset_sets_is_the_composed_value(
    preset: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot_environment(monkeypatch)
    raw = OmegaConf.to_container(
        OmegaConf.load(CONFIG_DIR / "deployment" / f"{preset}.yaml"), resolve=True
    )
    assert isinstance(raw, dict)
    raw.pop("defaults", None)
    composed = compose_config(preset).model_dump(mode="json")
    for path, value in _leaves(raw):
        got: object = composed
        for key in path:
            assert isinstance(got, dict), path
            got = got[key]
        assert got == value, f"{'.'.join(path)} of {preset}.yaml is overridden"
