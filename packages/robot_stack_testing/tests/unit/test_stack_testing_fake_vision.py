"""The fake vision node (real rclpy, the three VisionTask services from an in-memory table) and
the in-memory VisionTasks port: what the bridges' tests rely on them to do."""

from __future__ import annotations

import sys
import uuid
from collections.abc import Iterator

import pytest

from robot_ros_bridge import RemoteError, RosBridge, ServiceUnavailableError
from robot_ros_bridge.vision_tasks import RosVisionTasks
from robot_stack_testing import ProcessLauncher, async_wait_until
from robot_stack_testing.ros.fake_vision import FakeVisionNode, FakeVisionTasks


def _unique(prefix: str) -> str:
    return f"{prefix}_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def bridge() -> Iterator[RosBridge]:
    with RosBridge(_unique("client")) as b:
        yield b


async def test_the_in_memory_port_keeps_skills_and_records_every_call() -> None:
    tasks = FakeVisionTasks()
    created = await tasks.create(
        {"name": "door", "mode": "describe", "outputs": [{"name": "open"}], "watch": {"x": 1}}
    )
    assert created["topics"]["outputs"] == {"open": "/vision/door/open"}
    with pytest.raises(RemoteError, match="already exists"):
        await tasks.create({"name": "door", "mode": "describe"})
    await tasks.manage("door", "disable")
    [listed] = await tasks.list()
    assert (listed["enabled"], listed["once"], listed["watch"]) == (False, False, {"x": 1})
    await tasks.manage("door", "delete")
    with pytest.raises(RemoteError, match="no skill"):
        await tasks.manage("door", "enable")
    tasks.fail_with = ServiceUnavailableError("the node is gone")
    with pytest.raises(ServiceUnavailableError):
        await tasks.list()
    assert [call for call, _ in tasks.calls] == [
        "create",
        "create",
        "manage",
        "list",
        "manage",
        "manage",
        "list",
    ]


@pytest.mark.ros
async def test_the_fake_vision_node_auto_publishes_meta_without_masks_and_outputs(
    bridge: RosBridge,
) -> None:
    from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

    with FakeVisionNode(_unique("auto"), auto_publish_hz=20.0) as vision:
        tasks = RosVisionTasks(bridge, vision.name, timeout_s=10.0, wait_for_service_s=5.0)
        await tasks.create(
            {
                "name": "scene",
                "mode": "describe",
                "grounding": "a mug",
                "watch": {"output": "seen", "equals": True},
                "outputs": [{"name": "seen", "type": "boolean"}],
            }
        )
        metas: list[VisionDetectionArray] = []
        fulls: list[VisionDetectionArray] = []
        outs: list[str] = []
        bridge.create_subscription(
            VisionDetectionArray, "/vision/scene/detections_meta", metas.append
        )
        bridge.create_subscription(VisionDetectionArray, "/vision/scene/detections", fulls.append)
        bridge.create_subscription(
            StampedString, "/vision/scene/seen", lambda m: outs.append(m.data)
        )
        await async_wait_until(lambda: metas and fulls and outs, 10.0, "auto-published results")
        assert metas[0].detections[0].label == "a mug"
        assert len(metas[0].detections[0].mask.data) == 0
        assert len(fulls[0].detections[0].mask.data) == 16
        assert outs[0] == "false"
        listed = await tasks.list()
        assert listed[0]["watch"] == {"output": "seen", "equals": True}
        vision.fail_next["create"] = ("cloud_down", "the grounder is unreachable")
        with pytest.raises(RemoteError) as info:
            await tasks.create({"name": "other", "mode": "describe"})
        assert info.value.code == "cloud_down"
        with pytest.raises(RemoteError) as info:
            await tasks.create({"name": "scene", "mode": "describe"})
        assert info.value.code == "duplicate_name"
        with pytest.raises(RemoteError):
            await tasks.create({"name": "bad", "mode": "dance"})
        with pytest.raises(RemoteError):
            await tasks.manage("scene", "explode")  # type: ignore[arg-type]
        assert vision.skills()["scene"]["mode"] == "describe"


@pytest.mark.ros
async def test_the_node_runs_as_its_own_process_and_publishes_by_itself(
    bridge: RosBridge, launcher: ProcessLauncher
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    name = _unique("process_vision")
    argv = [sys.executable, "-m", "robot_stack_testing.ros.fake_vision", "--name", name]
    launcher.start("fake-vision", [*argv, "--hz", "20"])
    tasks = RosVisionTasks(bridge, name, timeout_s=10.0, wait_for_service_s=60.0)
    await tasks.create({"name": "cup", "mode": "segment_all"})
    metas: list[VisionDetectionArray] = []
    bridge.create_subscription(VisionDetectionArray, "/vision/cup/detections_meta", metas.append)
    await async_wait_until(lambda: metas, 10.0, "a result published by the node itself")
    assert metas[0].detections[0].label == "segment_all"
    await tasks.manage("cup", "enable")
    await tasks.manage("cup", "delete")
    assert await tasks.list() == []
