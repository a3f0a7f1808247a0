"""The gripper over ROS: pick a detection the vision node published, carry it, place it where
the robot stands — and every refusal a robot would give, with its error code. The world is read
from the node's parameters (what any ROS tool sees), not from the gripper's own words."""

from __future__ import annotations

import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from action_msgs.msg import GoalStatus
from rclpy.action.client import ActionClient
from rclpy.parameter import Parameter
from robot_manipulation_interfaces.action import Pick, Place
from robot_manipulation_interfaces.msg import DetectionRef
from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

from robot_sim.config import SimSettings
from robot_sim.manipulation_server import RESULT_QOS
from robot_stack_testing import wait_until

from ..conftest import WORLD
from .conftest import Sim

pytestmark = pytest.mark.ros

TOPIC = "/vision/find_object/detections"


@pytest.fixture
def settings(tmp_path: Path) -> SimSettings:
    return SimSettings(
        SIM_WORLD=WORLD,
        SIM_SCENES_DIR=tmp_path / "scenes",
        SIM_TIME_SCALE=20.0,
        SIM_FAILURES="off",
        SIM_PICK_S=2.0,
    )


class Arm:
    def __init__(self, sim: Sim) -> None:
        self.sim = sim
        self.pick = ActionClient(sim.client, Pick, "/manipulation/pick")
        self.place_client = ActionClient(sim.client, Place, "/manipulation/place")
        self.detections = sim.client.create_publisher(VisionDetectionArray, TOPIC, RESULT_QOS)

    def seen(self, *labels: str, age_s: float = 0.0) -> Any:
        """Publish a detection result like the vision node; its stamp once the gripper has it."""
        msg = VisionDetectionArray(skill="find_object")
        stamp = self.sim.client.get_clock().now().nanoseconds - int(age_s * 1e9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        msg.detections = [
            VisionDetection(label=label, score=0.9, kind="object") for label in labels
        ]
        self.detections.publish(msg)
        sightings = self.sim.node.manipulation.sightings
        wait_until(
            lambda: any(s.stamp_ns == stamp for s in sightings.of(TOPIC) or []),
            10.0,
            "the gripper to receive the detection",
        )
        return msg.header.stamp

    def send(self, client: ActionClient, goal: Any) -> Any:
        assert client.wait_for_server(timeout_sec=10.0)
        future = client.send_goal_async(goal)
        wait_until(future.done, 10.0, "the goal response")
        return future.result()

    def result(self, handle: Any) -> Any:
        future = handle.get_result_async()
        wait_until(future.done, 20.0, "the result")
        return future.result()

    def pick_goal(self, stamp: Any, label: str = "yellow package", index: int = -1) -> Any:
        return Pick.Goal(target=DetectionRef(topic=TOPIC, stamp=stamp, index=index, label=label))

    def do_pick(self, stamp: Any, **kwargs: Any) -> Any:
        handle = self.send(self.pick, self.pick_goal(stamp, **kwargs))
        assert handle.accepted
        return self.result(handle)

    def do_place(self, mode: int = Place.Goal.PLACE) -> Any:
        handle = self.send(self.place_client, Place.Goal(mode=mode))
        assert handle.accepted
        return self.result(handle)


def objects(sim: Sim, place: str) -> list[str]:
    return list(sim.node.get_parameter(f"places.{place}.objects").value)


def held(sim: Sim) -> str:
    return str(sim.node.get_parameter("gripper.held").value)


def set_params(sim: Sim, *params: Parameter[Any]) -> None:
    results = sim.node.set_parameters(list(params))
    assert all(r.successful for r in results), [r.reason for r in results]


def test_pick_carries_the_package_away_and_place_puts_it_where_the_robot_stands(sim: Sim) -> None:
    arm = Arm(sim)
    sim.go_to("mailroom")
    shelf = sim.node.camera.world.map.locations["mailroom"].pose()
    assert "yellow package" in sim.node.camera.shot(shelf).frame.labels
    outcome = arm.do_pick(arm.seen("cardboard box", "yellow package"), label="package")
    assert outcome.status == GoalStatus.STATUS_SUCCEEDED
    assert outcome.result.held.holding
    assert outcome.result.held.label == "yellow package"
    assert objects(sim, "mailroom") == ["cardboard box", "cardboard box"]
    assert held(sim) == "yellow package"
    assert "yellow package" not in sim.node.camera.shot(shelf).frame.labels  # the camera shows it
    sim.go_to("reception")
    placed = arm.do_place()
    assert placed.status == GoalStatus.STATUS_SUCCEEDED
    assert placed.result.placed_label == "yellow package"
    assert not placed.result.held.holding
    assert objects(sim, "reception") == ["blue folder", "yellow package"]
    assert "yellow package" not in objects(sim, "mailroom")
    desk = sim.node.camera.world.map.locations["reception"].pose()
    assert "yellow package" in sim.node.camera.shot(desk).frame.labels
    assert held(sim) == ""


def test_a_pick_refers_to_a_real_recent_detection_of_a_thing_that_is_here(sim: Sim) -> None:
    arm = Arm(sim)
    stamp = arm.seen("yellow package")
    unseen = arm.do_pick(stamp, label="red mug")  # the result shows no mug
    assert unseen.status == GoalStatus.STATUS_ABORTED
    assert unseen.result.error_code == Pick.Result.DETECTION_NOT_FOUND
    elsewhere = arm.do_pick(stamp)  # seen, but the robot stands at the dock: not in reach here
    assert elsewhere.result.error_code == Pick.Result.DETECTION_NOT_FOUND
    assert "dock" in elsewhere.result.error_msg
    sim.go_to("mailroom")
    wrong_index = arm.do_pick(arm.seen("cardboard box", "yellow package"), index=0)
    assert wrong_index.result.error_code == Pick.Result.DETECTION_NOT_FOUND
    old = arm.do_pick(arm.seen("yellow package", age_s=120.0))
    assert old.result.error_code == Pick.Result.DETECTION_STALE
    missing = stamp.__class__(sec=stamp.sec - 5, nanosec=stamp.nanosec)
    assert arm.do_pick(missing).result.error_code == Pick.Result.DETECTION_NOT_FOUND
    assert objects(sim, "mailroom")[0] == "yellow package"  # nothing moved
    assert held(sim) == ""


def test_injected_faults_fail_a_grasp_once_and_keep_a_thing_out_of_reach(sim: Sim) -> None:
    arm = Arm(sim)
    sim.go_to("mailroom")
    set_params(
        sim, Parameter("gripper.out_of_reach", Parameter.Type.STRING_ARRAY, ["yellow package"])
    )
    far = arm.do_pick(arm.seen("yellow package"))
    assert far.result.error_code == Pick.Result.OUT_OF_REACH
    set_params(
        sim,
        Parameter("gripper.out_of_reach", Parameter.Type.STRING_ARRAY, [""]),
        Parameter("gripper.fail_grasps", Parameter.Type.INTEGER, 1),
    )
    slipped = arm.do_pick(arm.seen("yellow package"))
    assert slipped.status == GoalStatus.STATUS_ABORTED
    assert slipped.result.error_code == Pick.Result.GRASP_FAILED
    assert not slipped.result.held.holding
    assert "yellow package" in objects(sim, "mailroom")
    again = arm.do_pick(arm.seen("yellow package"))  # the fault was used up: the retry holds
    assert again.status == GoalStatus.STATUS_SUCCEEDED
    twice = arm.do_pick(arm.seen("cardboard box"), label="cardboard box")
    assert twice.result.error_code == Pick.Result.ALREADY_HOLDING


def test_place_refuses_with_nothing_held_and_where_there_is_no_room(sim: Sim) -> None:
    arm = Arm(sim)
    empty = arm.do_place()
    assert empty.status == GoalStatus.STATUS_ABORTED
    assert empty.result.error_code == Place.Result.NOTHING_HELD
    set_params(sim, Parameter("gripper.held", Parameter.Type.STRING, "red mug"))
    full = ["white plate"] * 6
    set_params(sim, Parameter("places.dock.objects", Parameter.Type.STRING_ARRAY, full))
    no_room = arm.do_place(Place.Goal.RELEASE)
    assert no_room.result.error_code == Place.Result.NO_SURFACE
    assert held(sim) == "red mug"


def test_the_arm_waits_while_the_base_drives(sim: Sim) -> None:
    arm = Arm(sim)
    sim.node.drive.time_scale = 1.0
    far = sim.node.camera.world.map.locations["meeting_room"]
    drive = sim.send_goal(far.x, far.y)
    wait_until(lambda: sim.node.drive.state(time.monotonic()).driving, 10.0, "a moving base")
    moving = arm.do_pick(arm.seen("yellow package"))
    assert moving.result.error_code == Pick.Result.ARM_NOT_READY
    drive.cancel_goal_async()


def test_a_cancelled_pick_changes_nothing(sim: Sim) -> None:
    arm = Arm(sim)
    sim.go_to("mailroom")
    manipulation = sim.node.manipulation
    manipulation._settings = replace(manipulation._settings, pick_s=600.0)  # a slow arm
    phases: list[str] = []
    assert arm.pick.wait_for_server(timeout_sec=10.0)
    sent = arm.pick.send_goal_async(
        arm.pick_goal(arm.seen("yellow package")),
        feedback_callback=lambda m: phases.append(m.feedback.phase),
    )
    wait_until(lambda: phases, 10.0, "the pick's first phase")
    handle = sent.result()
    cancel = handle.cancel_goal_async()
    wait_until(cancel.done, 10.0, "the cancel answer")
    outcome = arm.result(handle)
    assert outcome.status == GoalStatus.STATUS_CANCELED
    assert phases[0] == "locating"
    assert objects(sim, "mailroom")[0] == "yellow package"
    assert held(sim) == ""


def test_a_pick_waits_briefly_for_its_detection_to_arrive(sim: Sim) -> None:
    """The goal and the data plane are separate channels: a goal may overtake its result."""
    arm = Arm(sim)
    sim.go_to("mailroom")
    arm.seen("cardboard box")  # the gripper already follows the topic
    msg = VisionDetectionArray(skill="find_object")
    msg.header.stamp = sim.client.get_clock().now().to_msg()
    msg.detections = [VisionDetection(label="yellow package", score=0.9, kind="object")]
    handle = arm.send(arm.pick, arm.pick_goal(msg.header.stamp))  # before the result is out
    arm.detections.publish(msg)
    assert arm.result(handle).status == GoalStatus.STATUS_SUCCEEDED
    assert held(sim) == "yellow package"


def test_an_arm_held_by_a_supervisor_lock_waits_and_gives_up_only_after_the_allowance(
    sim: Sim,
) -> None:
    """robot-sim's twist_mux view (SIM_SUPERVISOR_LOCK) holds the arm too, as it holds the
    base: while a lock is locked the arm does not move; it goes on when the lock opens, and a
    hold longer than the allowance ends the goal ARM_NOT_READY with the world as it was."""
    arm = Arm(sim)
    sim.go_to("mailroom")
    locked = [True]
    server = sim.node.manipulation
    server.held, server.held_timeout_s = (lambda: locked[0]), 0.3
    try:
        outcome = arm.do_pick(arm.seen("yellow package"))
        assert outcome.status == GoalStatus.STATUS_ABORTED
        assert outcome.result.error_code == Pick.Result.ARM_NOT_READY
        assert "supervisor lock" in outcome.result.error_msg
        assert "yellow package" in objects(sim, "mailroom")
        assert held(sim) == ""
        server.held_timeout_s = 30.0
        opens = threading.Timer(0.5, lambda: locked.__setitem__(0, False))
        opens.start()  # a brief hold: the pick waits and then goes on
        started = time.monotonic()
        assert arm.do_pick(arm.seen("yellow package")).status == GoalStatus.STATUS_SUCCEEDED
        assert time.monotonic() - started >= 0.5
        assert held(sim) == "yellow package"
        locked[0], server.held_timeout_s = True, 0.3
        placed = arm.do_place()
        assert placed.status == GoalStatus.STATUS_ABORTED
        assert placed.result.error_code == Place.Result.ARM_NOT_READY
        assert held(sim) == "yellow package"
    finally:
        server.held = lambda: False
