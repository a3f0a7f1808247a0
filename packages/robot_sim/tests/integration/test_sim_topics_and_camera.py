"""The pose, odometry and camera topics, the camera's scene per place, and world changes —
as a ROS subscriber and the offline grounder (the vision node's default) see them."""

from __future__ import annotations

import asyncio
import json
import time

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from robot_mcp_perception.models.annotation import AnnotationGrounder
from robot_sim.config import SimSettings
from robot_stack_testing import wait_until

from .conftest import Sim

pytestmark = pytest.mark.ros


def test_pose_and_odometry_are_published_at_ten_hertz_or_more(sim: Sim) -> None:
    start = time.monotonic()
    wait_until(lambda: len(sim.odom.since(start)) >= 25, 10.0, "25 odometry messages")
    window = time.monotonic() - start
    assert len(sim.amcl.since(start)) >= 10 * window * 0.8
    assert len(sim.odom.since(start)) >= 10 * window * 0.8
    amcl, odom = sim.amcl.last(), sim.odom.last()
    assert amcl.header.frame_id == "map"
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    dock = sim.node.camera.world.map.locations["dock"]
    assert (amcl.pose.pose.position.x, amcl.pose.pose.position.y) == (dock.x, dock.y)
    assert amcl.pose.covariance[0] > 0


def test_odometry_reports_the_speed_while_driving(sim: Sim) -> None:
    sim.node.drive.time_scale = 1.0
    far = sim.node.camera.world.map.locations["meeting_room"]
    handle = sim.send_goal(far.x, far.y)
    wait_until(lambda: _speed(sim) > 0, 10.0, "a moving robot")
    handle.cancel_goal_async()
    wait_until(lambda: _speed(sim) == 0, 10.0, "a halted robot")


def _speed(sim: Sim) -> float:
    last = sim.odom.last()
    return -1.0 if last is None else float(last.twist.twist.linear.x)


def _pixels(msg: object) -> np.ndarray:  # type: ignore[type-arg]
    assert msg.encoding == "rgb8"  # type: ignore[attr-defined]
    return np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.width, 3)  # type: ignore[attr-defined]


def _latest_frame(sim: Sim, after: float) -> np.ndarray:  # type: ignore[type-arg]
    wait_until(lambda: sim.images.since(after), 10.0, "a camera frame")
    return _pixels(sim.images.since(after)[-1])


def _found(grounder: AnnotationGrounder, image: np.ndarray, query: str) -> set[str]:  # type: ignore[type-arg]
    return {t.label for t in asyncio.run(grounder.ground(image, query)).targets}


def test_the_camera_sees_the_room_the_robot_is_in(sim: Sim, settings: SimSettings) -> None:
    grounder = AnnotationGrounder(str(settings.scenes_dir))
    start = time.monotonic()
    dock = _latest_frame(sim, start)
    assert dock.shape == (480, 640, 3)
    assert _found(grounder, dock, "the mug") == set()
    assert sim.go_to("kitchen").result.error_code == 0
    kitchen = _latest_frame(sim, time.monotonic())
    assert _found(grounder, kitchen, "the mug") == {"red mug"}
    assert sim.go_to("mailroom", timeout_s=40.0).result.error_code == 0  # round by the east
    mailroom = _latest_frame(sim, time.monotonic())
    assert _found(grounder, mailroom, "the mug") == set()
    assert _found(grounder, mailroom, "the package") == {"yellow package"}
    info = sim.infos.last()
    assert (info.width, info.height, info.header.frame_id) == (640, 480, settings.camera_frame_id)
    assert info.k[2] == 320.0
    assert info.k[0] == info.k[4] > 0


def test_while_driving_every_frame_is_new_and_annotated_before_it_is_published(
    sim: Sim, settings: SimSettings
) -> None:
    sim.node.drive.time_scale = 1.0
    far = sim.node.camera.world.map.locations["meeting_room"]
    handle = sim.send_goal(far.x, far.y)
    start = time.monotonic()
    wait_until(lambda: len(sim.images.since(start)) >= 3, 15.0, "three frames while driving")
    handle.cancel_goal_async()
    frames = [bytes(m.data) for m in sim.images.since(start)[:3]]
    assert len(set(frames)) == 3  # the robot moved between them
    grounder = AnnotationGrounder(str(settings.scenes_dir))
    for pixels in frames:
        image = np.frombuffer(pixels, np.uint8).reshape(480, 640, 3)
        answer = asyncio.run(grounder.ground(image, "anything", mode="describe")).answer
        assert answer
        assert "not annotated" not in answer


def test_someone_takes_the_mug_through_a_parameter(sim: Sim, settings: SimSettings) -> None:
    assert sim.go_to("kitchen").result.error_code == 0
    grounder = AnnotationGrounder(str(settings.scenes_dir))
    parameters = AsyncParameterClient(sim.client, "robot_sim")
    assert parameters.wait_for_services(timeout_sec=10.0)
    refused = parameters.set_parameters(
        [Parameter("places.kitchen.objects", Parameter.Type.STRING_ARRAY, ["unicorn"])]
    )
    wait_until(refused.done, 10.0, "the refusal")
    answer = refused.result().results[0]
    assert not answer.successful
    assert "unknown objects ['unicorn']" in answer.reason
    taken = parameters.set_parameters(
        [Parameter("places.kitchen.objects", Parameter.Type.STRING_ARRAY, ["green bottle"])]
    )
    wait_until(taken.done, 10.0, "the change")
    assert taken.result().results[0].successful
    changed = time.monotonic()
    wait_until(
        lambda: (
            sim.images.since(changed)
            and _found(grounder, _pixels(sim.images.since(changed)[-1]), "the bottle")
        ),
        10.0,
        "the new kitchen scene",
    )
    frame = _pixels(sim.images.since(changed)[-1])
    assert _found(grounder, frame, "the mug") == set()
    emptied = parameters.set_parameters(
        [Parameter("places.kitchen.objects", Parameter.Type.STRING_ARRAY, [])]
    )
    wait_until(emptied.done, 10.0, "emptying the kitchen")
    assert emptied.result().results[0].successful
    assert sim.node.camera.world.objects_at("kitchen") == ()


def test_the_world_command_changes_a_running_sim(
    sim: Sim, capsys: pytest.CaptureFixture[str]
) -> None:
    from robot_sim.world_cli import main as world

    assert world(["kitchen", "green bottle"]) == 0
    assert sim.node.camera.world.objects_at("kitchen") == ("green bottle",)
    assert world(["kitchen", "unicorn"]) == 1
    assert sim.node.camera.world.objects_at("kitchen") == ("green bottle",)
    assert world(["--active", "false"]) == 0
    assert not sim.node.navigator.accepting
    assert world(["--door", "mailroom_west_door=open", "--door", "kitchen_door=closed"]) == 0
    assert sim.node.camera.world.closed_doors() == {"kitchen_door"}
    assert world(["--door", "cellar=open"]) == 1  # no such door parameter: refused
    with pytest.raises(SystemExit):
        world(["--door", "kitchen_door=ajar"])
    assert world(["kitchen", "--node", "no_such_node", "--timeout", "1"]) == 2
    assert world(["--fail-grasps", "1", "--out-of-reach", "red mug", "--held", ""]) == 0
    assert sim.node.gripper.faults.fail_grasps == 1
    assert sim.node.gripper.faults.out_of_reach == frozenset({"red mug"})
    assert world(["--held", "unicorn"]) == 1
    capsys.readouterr()
    assert world(["--show"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["places"]["kitchen"] == ["green bottle"]
    assert shown["places"]["mailroom"][0] == "yellow package"
    assert shown["held"] is None
    with pytest.raises(SystemExit):
        world([])  # nothing to change: usage error
