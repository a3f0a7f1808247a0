"""Navigation's ROS peers as the tests and benchmarks run them, each in its own process: the
small NavigateToPose server and the credential-less intruder that sends it goals and publishes
a spoofed lock, pose and map."""

from __future__ import annotations

import json
import sys
import uuid
from pathlib import Path
from typing import Any

import pytest

from robot_ros_bridge import RosBridge
from robot_stack_testing import LaunchedProcess, ProcessLauncher, async_wait_until, wait_until

pytestmark = [pytest.mark.ros]


def events(process: LaunchedProcess, name: str) -> list[dict[str, Any]]:
    lines = [line for line in process.log().splitlines() if line.startswith("{")]
    return [e for e in (json.loads(line) for line in lines) if e.get("event") == name]


def start_nav2(launcher: ProcessLauncher) -> LaunchedProcess:
    argv = [sys.executable, "-m", "robot_stack_testing.navigation.nav2_server"]
    process = launcher.start(
        "fake-nav2", [*argv, "--speed", "10", "--abort", "0,3,208,door closed", "--trace"]
    )
    wait_until(lambda: "fake_nav2_ready" in process.log(), 30, "the fake Nav2 to start")
    return process


def intruder(launcher: ProcessLauncher, name: str, *args: str) -> LaunchedProcess:
    argv = [sys.executable, "-m", "robot_stack_testing.navigation.intruder", "--node-name", name]
    return launcher.start(name, [*argv, *args, "--seconds", "60"])


async def test_the_intruder_drives_the_fake_nav2_and_publishes_its_spoofs(
    launcher: ProcessLauncher, tmp_path: Path
) -> None:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from nav_msgs.msg import OccupancyGrid
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Bool

    latched = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )

    tag = uuid.uuid4().hex[:8]
    nav2 = start_nav2(launcher)
    locks: list[bool] = []
    poses: list[Any] = []
    maps: list[Any] = []
    with RosBridge(f"watcher_{tag}") as bridge:
        bridge.create_subscription(Bool, f"/lock_{tag}", lambda m: locks.append(m.data))
        bridge.create_subscription(PoseWithCovarianceStamped, f"/pose_{tag}", poses.append)
        bridge.create_subscription(OccupancyGrid, f"/map_{tag}", maps.append, latched)
        spoofer = intruder(
            launcher,
            f"spoofer_{tag}",
            *("--goal", "1,0", "--lock-topic", f"/lock_{tag}", "--lock-hz", "50"),
            *(
                "--pose",
                "5,6",
                "--pose-topic",
                f"/pose_{tag}",
                "--map",
                "--map-topic",
                f"/map_{tag}",
            ),
        )
        await async_wait_until(lambda: events(spoofer, "goal_ended"), 30, spoofer.log())
        await async_wait_until(lambda: locks, 10, "the spoofed lock")
        await async_wait_until(lambda: poses, 10, "the spoofed pose")
        await async_wait_until(lambda: maps, 10, "the spoofed map")
    assert events(spoofer, "goal_accepted")[0]["x"] == 1.0
    assert events(spoofer, "goal_ended")[0]["status"] == "succeeded"
    assert set(locks) == {False}
    assert (poses[0].pose.pose.position.x, poses[0].pose.pose.position.y) == (5.0, 6.0)
    assert (maps[0].info.width, maps[0].info.height) == (4, 4)
    launcher.stop(spoofer)
    assert events(spoofer, "intruder_stopped")

    go = tmp_path / "go"
    waiting = intruder(launcher, f"late_{tag}", "--goal", "0,3", "--wait-for", str(go))
    wait_until(lambda: events(waiting, "intruder_waiting"), 30, "the intruder to wait")
    assert not events(waiting, "intruder_ready")
    go.touch()
    wait_until(lambda: events(waiting, "goal_ended"), 30, "the second goal to end")
    assert events(waiting, "goal_ended")[0]["status"] == "aborted"
    log = nav2.log()
    assert "goal_succeeded" in log
    assert "goal_aborted code=208" in log
    assert "trace goal_received" in log
    assert "trace feedback" in log
