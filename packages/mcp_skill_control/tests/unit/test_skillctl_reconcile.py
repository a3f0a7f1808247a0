"""A create_vision_task that times out is reconciled against the node's list (issue 13 item
10), with the VisionTasks port faked: a node whose create lands ``late_s`` after it timed out."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from mcp_skill_control.catalog import Catalog
from mcp_skill_control.config import DEFAULT_CATALOG
from mcp_skill_control.reconcile import CreateReconciler
from mcp_skill_control.tools import SkillControl
from robot_ros_bridge import ServiceTimeoutError, ServiceUnavailableError
from robot_stack_testing import async_wait_until
from robot_stack_testing.ros.fake_vision import FakeVisionTasks


class LateNode(FakeVisionTasks):
    """create times out; the skill appears ``late_s`` later (or never, if None); the first
    ``list_failures`` lists after a create fail; ``recovered`` makes creates plain again."""

    def __init__(self, late_s: float | None, list_failures: int = 0) -> None:
        super().__init__()
        self.late_s = late_s
        self.list_failures_after_create = list_failures
        self.list_failures = 0
        self.recovered = False

    async def create(self, skill: dict[str, Any]) -> dict[str, Any]:
        if self.recovered:
            return await super().create(skill)
        self.calls.append(("create", skill))
        self.list_failures = self.list_failures_after_create
        if self.late_s is not None:
            asyncio.get_running_loop().call_later(self.late_s, self._land, dict(skill))
        raise ServiceTimeoutError("/vision_node/create_vision_task did not answer within 0.5 s")

    def _land(self, skill: dict[str, Any]) -> None:
        self.skills[skill["name"]] = skill
        self.enabled[skill["name"]] = True

    async def list(self) -> list[dict[str, Any]]:
        if self.list_failures:
            self.list_failures -= 1
            raise ServiceUnavailableError("no server for /vision_node/list_vision_tasks")
        return await super().list()


def control(
    node: FakeVisionTasks, confirm_s: float, sweep_s: float = 5.0
) -> tuple[SkillControl, CreateReconciler]:
    reconciler = CreateReconciler(node, confirm_s=confirm_s, sweep_s=sweep_s, poll_s=0.02)
    return SkillControl(Catalog.load(DEFAULT_CATALOG), node, reconciler), reconciler


async def test_a_skill_that_appears_within_the_window_is_adopted() -> None:
    node = LateNode(late_s=0.1, list_failures=1)
    skills, _ = control(node, confirm_s=3.0)
    made = await skills.instantiate("describe_scene", {})
    await skills.close()
    assert made["skill_id"] == "describe_scene"
    assert list(node.skills) == ["describe_scene"]


async def test_a_skill_that_appears_late_is_reported_and_then_removed() -> None:
    node = LateNode(late_s=0.3)
    skills, _ = control(node, confirm_s=0.05)
    with pytest.raises(ServiceTimeoutError, match="not running"):
        await skills.instantiate("describe_scene", {})
    await async_wait_until(
        lambda: ("manage", {"task_name": "describe_scene", "action": "delete"}) in node.calls,
        5.0,
        "the late skill deleted",
    )
    await skills.close()
    assert node.skills == {}


async def test_a_later_successful_create_of_the_name_cancels_the_sweep() -> None:
    node = LateNode(late_s=None)
    skills, reconciler = control(node, confirm_s=0.05, sweep_s=30.0)
    with pytest.raises(ServiceTimeoutError):
        await skills.instantiate("describe_scene", {})
    assert reconciler.sweeping() == ["describe_scene"]
    node.recovered = True
    made = await skills.instantiate("describe_scene", {})
    assert made["skill_id"] == "describe_scene"
    assert reconciler.sweeping() == []
    await skills.close()
    assert list(node.skills) == ["describe_scene"]
