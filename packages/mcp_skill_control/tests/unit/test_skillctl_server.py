"""The MCP surface of skill_control, through the SDK's in-memory client (no ROS)."""

import json
from pathlib import Path

import pytest
from mcp import Client

from mcp_skill_control.composition import build_app
from mcp_skill_control.config import DEFAULT_CATALOG, SkillControlConfig
from robot_ros_bridge import ServiceTimeoutError
from robot_stack_testing.kit.tool_calls import tool_answer
from robot_stack_testing.ros.fake_vision import FakeVisionTasks


@pytest.fixture
def tasks() -> FakeVisionTasks:
    return FakeVisionTasks()


@pytest.fixture
def config() -> SkillControlConfig:
    return SkillControlConfig()


async def test_the_server_lists_its_tools_with_planner_docstrings(
    config: SkillControlConfig, tasks: FakeVisionTasks
) -> None:
    app = build_app(config, tasks=tasks)
    async with Client(app.server) as client:
        tools = {t.name: t for t in (await client.list_tools()).tools}
    assert set(tools) == {
        "list_skill_templates",
        "list_running_skills",
        "instantiate_skill",
        "instantiate_raw_skill",
        "prewarm_skill",
        "stop_skill",
        "set_skill_enabled",
    }
    assert all("Call this" in (t.description or "") for t in tools.values())
    assert app.server.name == "skill_control"


async def test_the_tools_round_trip_through_mcp(
    config: SkillControlConfig, tasks: FakeVisionTasks
) -> None:
    app = build_app(config, tasks=tasks)
    async with Client(app.server) as client:
        templates = await tool_answer(client, "list_skill_templates")
        assert next(t["name"] for t in templates["templates"]) == "find_object"
        made = await tool_answer(
            client,
            "instantiate_skill",
            {"template": "watch_for", "params": {"condition": "door open"}},
        )
        assert made["task_id"] == "watch-watch_for"
        assert made["state"] == "running"
        raw = await tool_answer(
            client,
            "instantiate_raw_skill",
            {"skill": {"name": "shelf", "mode": "region", "grounding": "shelf"}},
        )
        assert raw["topic"] == "/vision/shelf/detections"
        warm = await tool_answer(
            client, "prewarm_skill", {"template": "free_space", "params": {"what": "box"}}
        )
        assert warm["prewarm"] is True
        assert await tool_answer(
            client, "set_skill_enabled", {"skill_id": "shelf", "enabled": False}
        ) == {
            "skill_id": "shelf",
            "enabled": False,
        }
        running = await tool_answer(client, "list_running_skills")
        assert {s["skill_id"] for s in running["skills"]} == {
            "watch_for",
            "shelf",
            "prewarm_free_space",
        }
        assert await tool_answer(client, "stop_skill", {"skill_id": "shelf"}) == {
            "skill_id": "shelf",
            "stopped": True,
        }


async def test_catalog_and_node_refusals_are_clean_tool_errors(
    config: SkillControlConfig, tasks: FakeVisionTasks
) -> None:
    app = build_app(config, tasks=tasks)
    async with Client(app.server) as client:
        missing = await tool_answer(client, "instantiate_skill", {"template": "find_object"})
        assert missing["_error"]["error"] == "missing_params"
        unknown = await tool_answer(
            client, "instantiate_skill", {"template": "teleport", "params": {}}
        )
        assert unknown["_error"]["error"] == "unknown_template"
        ghost = await tool_answer(client, "stop_skill", {"skill_id": "ghost"})
        assert ghost["_error"] == {"error": "unknown_skill", "detail": "no skill named 'ghost'"}
        tasks.fail_with = ServiceTimeoutError("/vision_node/list_vision_tasks did not answer")
        timeout = await tool_answer(client, "list_running_skills")
        assert timeout["_error"]["error"] == "service_timeout"
        assert "did not answer" in timeout["_error"]["detail"]


def test_config_reads_the_spec_environment(tmp_path: Path) -> None:
    catalog = tmp_path / "skills.yaml"
    catalog.write_text(DEFAULT_CATALOG.read_text(encoding="utf-8"), encoding="utf-8")
    config = SkillControlConfig.from_env(
        {
            "VISION_NODE_NAME": "eyes",
            "SKILLS_CATALOG": str(catalog),
            "SKILL_CONTROL_CALL_TIMEOUT_S": "2.5",
        }
    )
    assert config.vision_node_name == "eyes"
    assert config.skills_catalog == catalog
    assert config.call_timeout_s == 2.5
    assert SkillControlConfig.from_env({}).skills_catalog == DEFAULT_CATALOG


def test_config_refuses_a_missing_catalog_at_start_up(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not a file"):
        SkillControlConfig.from_env({"SKILLS_CATALOG": str(tmp_path / "none.yaml")})
    with pytest.raises(ValueError):
        SkillControlConfig.from_env({"SKILL_CONTROL_CALL_TIMEOUT_S": "-1"})


def test_the_catalog_ships_inside_the_package() -> None:
    assert DEFAULT_CATALOG.is_file()
    assert DEFAULT_CATALOG.parent.parent.name == "mcp_skill_control"


async def test_every_tool_answers_with_structured_content_and_an_object_schema(
    config: SkillControlConfig, tasks: FakeVisionTasks
) -> None:
    app = build_app(config, tasks=tasks)
    async with Client(app.server) as client:
        tools = (await client.list_tools()).tools
        result = await client.call_tool(
            "instantiate_skill", {"template": "find_object", "params": {"query": "mug"}}
        )
    assert all((t.output_schema or {}).get("type") == "object" for t in tools)
    assert not result.is_error
    assert isinstance(result.structured_content, dict)
    assert result.structured_content["topic"] == "/vision/find_object/detections"
    assert "result" not in result.structured_content  # not a JSON string wrapped in "result"
    assert json.loads(result.content[0].text) == result.structured_content  # type: ignore[union-attr]


async def test_instantiate_skill_accepts_numbers_and_booleans_the_template_declares(
    tmp_path: Path, tasks: FakeVisionTasks
) -> None:
    catalog = tmp_path / "skills.yaml"
    catalog.write_text(
        "templates:\n"
        "  - name: look\n"
        "    params: [{name: rate, type: number}, {name: once, type: boolean}]\n"
        "    skill: {mode: describe, rate_hz: '{rate}', once: '{once}'}\n",
        encoding="utf-8",
    )
    app = build_app(SkillControlConfig(skills_catalog=catalog), tasks=tasks)
    async with Client(app.server) as client:
        made = await tool_answer(
            client, "instantiate_skill", {"template": "look", "params": {"rate": 2.5, "once": True}}
        )
        wrong = await tool_answer(
            client, "instantiate_skill", {"template": "look", "params": {"rate": "x", "once": 1}}
        )
    assert made["skill_id"] == "look"
    assert (tasks.skills["look"]["rate_hz"], tasks.skills["look"]["once"]) == (2.5, True)
    assert wrong["_error"]["error"] == "invalid_params"
