"""SkillControl (the tools' logic) against the in-memory fake of the VisionTasks port."""

import pytest

from mcp_skill_control.catalog import Catalog, CatalogError
from mcp_skill_control.config import DEFAULT_CATALOG
from mcp_skill_control.tools import SkillControl
from robot_ros_bridge import RemoteError, ServiceUnavailableError
from robot_stack_testing.ros.fake_vision import FakeVisionTasks


@pytest.fixture
def tasks() -> FakeVisionTasks:
    return FakeVisionTasks()


@pytest.fixture
def control(tasks: FakeVisionTasks) -> SkillControl:
    return SkillControl(Catalog.load(DEFAULT_CATALOG), tasks)


async def test_instantiate_creates_the_filled_skill_and_returns_its_topics(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    result = await control.instantiate("find_object", {"query": "scissors on top"})
    assert result["skill_id"] == "find_object"
    assert result["topic"] == "/vision/find_object/detections"
    assert result["meta_topic"] == "/vision/find_object/detections_meta"
    assert result["semantic_topics"] == ["/vision/find_object/found"]
    assert "task_id" not in result
    created = [arg for call, arg in tasks.calls if call == "create"]
    assert created[0]["grounding"] == "the scissors on top"


async def test_a_name_collision_gets_a_counter_suffix_and_is_tracked(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    first = await control.instantiate("find_object", {"query": "cup"})
    second = await control.instantiate("find_object", {"query": "box"})
    third = await control.instantiate("find_object", {"query": "pen"})
    assert [first["skill_id"], second["skill_id"], third["skill_id"]] == [
        "find_object",
        "find_object_2",
        "find_object_3",
    ]
    assert second["topic"] == "/vision/find_object_2/detections"
    assert tasks.skills["find_object_2"]["grounding"] == "the box"
    running = (await control.running_skills())["skills"]
    by_id = {s["skill_id"]: s for s in running}
    assert by_id["find_object_2"]["template"] == "find_object"
    assert by_id["find_object_2"]["params"] == {"query": "box"}


async def test_a_watcher_template_returns_a_running_watch_task(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    result = await control.instantiate("watch_for", {"condition": "the door is open"})
    assert result["task_id"] == "watch-watch_for"
    assert result["state"] == "running"
    assert result["server"] == "perception"
    assert tasks.skills["watch_for"]["watch"] == {"output": "triggered", "equals": True}
    running = (await control.running_skills())["skills"]
    assert running[0]["task_id"] == "watch-watch_for"


async def test_a_new_watcher_never_reuses_a_finished_watchers_task_id(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    """Issue 23 item 6: the previous watcher's late events must not match the new one."""
    first = await control.instantiate("watch_for", {"condition": "scissors"})
    await control.stop(first["skill_id"])
    second = await control.instantiate("watch_for", {"condition": "a dog"})
    assert first["task_id"] == "watch-watch_for"
    assert second["skill_id"] == "watch_for_2"
    assert second["task_id"] == "watch-watch_for_2"
    assert tasks.skills["watch_for_2"]["watch"] == {"output": "triggered", "equals": True}
    # other skills still take a freed name again
    found = await control.instantiate("find_object", {"query": "cup"})
    await control.stop(found["skill_id"])
    again = await control.instantiate("find_object", {"query": "box"})
    assert again["skill_id"] == found["skill_id"] == "find_object"


async def test_stop_deletes_and_set_enabled_pauses_the_skill(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    await control.instantiate("describe_scene", {})
    assert await control.set_enabled("describe_scene", False) == {
        "skill_id": "describe_scene",
        "enabled": False,
    }
    assert tasks.enabled["describe_scene"] is False
    assert (await control.running_skills())["skills"][0]["enabled"] is False
    await control.set_enabled("describe_scene", True)
    assert tasks.enabled["describe_scene"] is True
    assert await control.stop("describe_scene") == {"skill_id": "describe_scene", "stopped": True}
    assert ("manage", {"task_name": "describe_scene", "action": "delete"}) in tasks.calls
    assert tasks.skills == {}


async def test_stopping_an_unknown_skill_surfaces_the_nodes_error(
    control: SkillControl,
) -> None:
    with pytest.raises(RemoteError) as info:
        await control.stop("ghost")
    assert info.value.code == "unknown_skill"


async def test_a_raw_skill_is_validated_with_the_vision_schema_before_any_call(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    with pytest.raises(CatalogError) as info:
        await control.instantiate_raw({"name": "x", "mode": "dance"})
    assert info.value.code == "invalid_mode"
    assert tasks.calls == []
    result = await control.instantiate_raw({"mode": "region", "grounding": "an empty shelf"})
    assert result["skill_id"] == "raw_region"
    assert "template" not in result


async def test_prewarm_creates_a_prewarm_skill_only_for_grounding_templates(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    result = await control.prewarm("find_object", {"query": "red mug"})
    assert result["prewarm"] is True
    assert result["grounding"] == "the red mug"
    spec = tasks.skills[result["skill_id"]]
    assert spec["prewarm"] is True
    assert spec["once"] is True
    with pytest.raises(CatalogError) as info:
        await control.prewarm("describe_scene", {})
    assert info.value.code == "nothing_to_prewarm"


async def test_a_race_on_the_name_retries_with_the_next_suffix(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    original_list = tasks.list

    async def list_missing_one() -> list[dict[str, object]]:
        return [s for s in await original_list() if s["name"] != "segment_all"]

    await control.instantiate("segment_all", {})
    tasks.list = list_missing_one  # type: ignore[method-assign]
    result = await control.instantiate("segment_all", {})
    assert result["skill_id"] == "segment_all_2"


async def test_an_unavailable_vision_node_propagates_the_bridge_error(
    control: SkillControl, tasks: FakeVisionTasks
) -> None:
    tasks.fail_with = ServiceUnavailableError("no server for /vision_node/list_vision_tasks")
    with pytest.raises(ServiceUnavailableError):
        await control.instantiate("segment_all", {})
    with pytest.raises(ServiceUnavailableError):
        await control.running_skills()


def test_templates_lists_name_description_and_params(control: SkillControl) -> None:
    templates = control.templates()["templates"]
    assert templates[0] == {
        "name": "find_object",
        "description": "Locate and segment a specific object the user names.",
        "params": ["query"],
        "param_types": {"query": "string"},
        "watcher": False,
        "mode": "ground_and_segment",
    }
