"""A robot_sim node spinning in this process (own rclpy context) and a client node beside it:
everything between them crosses ROS (DDS on loopback, the run's domain id)."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor

from robot_sim.config import SimSettings
from robot_sim.main import build
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros


@dataclass
class Received:
    """Messages one subscription got, with their arrival times (monotonic)."""

    messages: list[Any] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, message: Any, at: float) -> None:
        with self.lock:
            self.messages.append(message)
            self.times.append(at)

    def last(self) -> Any:
        with self.lock:
            return self.messages[-1] if self.messages else None

    def since(self, start: float) -> list[Any]:
        with self.lock:
            return [m for m, t in zip(self.messages, self.times, strict=True) if t >= start]


@dataclass
class Sim:
    node: Any
    client: Any
    context: Context
    action: Any
    amcl: Received
    odom: Received
    images: Received
    plans: Received
    infos: Received
    costmaps: Received

    def send_goal(
        self,
        x: float,
        y: float,
        frame: str = "map",
        behavior_tree: str = "",
        feedback: Received | None = None,
        theta: float = 0.0,
    ) -> Any:
        """Send a goal; the goal handle once the server answered (accepted or not)."""
        from nav2_msgs.action import NavigateToPose

        from robot_sim import messages
        from robot_site_map import Pose

        goal = NavigateToPose.Goal(behavior_tree=behavior_tree)
        goal.pose = messages.pose_stamped(
            Pose(x, y, theta), self.client.get_clock().now().to_msg(), frame
        )
        assert self.action.wait_for_server(timeout_sec=10.0), "no NavigateToPose server"
        sink = feedback
        future = self.action.send_goal_async(
            goal,
            feedback_callback=(lambda msg: sink.add(msg.feedback, time.monotonic()))
            if sink is not None
            else None,
        )
        wait_until(future.done, 10.0, "the goal response")
        return future.result()

    def result(self, handle: Any, timeout_s: float = 20.0) -> Any:
        future = handle.get_result_async()
        wait_until(future.done, timeout_s, "the goal result")
        return future.result()

    def go_to(self, place: str, timeout_s: float = 20.0) -> Any:
        location = self.node.camera.world.map.locations[place]
        handle = self.send_goal(location.x, location.y, theta=location.theta)
        assert handle.accepted
        return self.result(handle, timeout_s)


def distance(a: Any, x: float, y: float) -> float:
    return math.hypot(a.position.x - x, a.position.y - y)


@pytest.fixture
def sim(settings: SimSettings) -> Iterator[Sim]:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from nav2_msgs.action import NavigateToPose
    from nav_msgs.msg import OccupancyGrid, Odometry, Path
    from rclpy.action.client import ActionClient
    from rclpy.node import Node
    from sensor_msgs.msg import CameraInfo, Image

    from robot_sim.node import (
        AMCL_QOS,
        CAMERA_QOS,
        COSTMAP_TOPIC,
        LATCHED_QOS,
        PLAN_QOS,
        PLAN_TOPIC,
        SimNode,
    )  # fmt: skip

    context = Context()
    import rclpy

    rclpy.init(context=context)
    executor = MultiThreadedExecutor(num_threads=6, context=context)
    drive, camera = build(settings)
    node = SimNode(settings, drive, camera, context=context)
    client = Node("robot_sim_test_client", context=context)
    amcl, odom, images = Received(), Received(), Received()
    plans, infos, costmaps = Received(), Received(), Received()
    client.create_subscription(Path, PLAN_TOPIC, lambda m: plans.add(m, time.monotonic()), PLAN_QOS)
    client.create_subscription(
        CameraInfo, settings.camera_info_topic, lambda m: infos.add(m, time.monotonic()), CAMERA_QOS
    )
    client.create_subscription(
        OccupancyGrid, COSTMAP_TOPIC, lambda m: costmaps.add(m, time.monotonic()), LATCHED_QOS
    )
    client.create_subscription(
        PoseWithCovarianceStamped, "/amcl_pose", lambda m: amcl.add(m, time.monotonic()), AMCL_QOS
    )
    client.create_subscription(Odometry, "/odom", lambda m: odom.add(m, time.monotonic()), 10)
    client.create_subscription(
        Image, settings.camera_topic, lambda m: images.add(m, time.monotonic()), CAMERA_QOS
    )
    action = ActionClient(client, NavigateToPose, settings.action_name)
    executor.add_node(node)
    executor.add_node(client)
    stopping = threading.Event()

    def spin() -> None:
        while not stopping.is_set():
            try:
                executor.spin()
            except Exception:  # as robot_sim.main.spin_on: a failed reply is not the sim's end
                if stopping.is_set():
                    return  # teardown: rclpy may still hand the spin loop a handle it destroys
                logging.getLogger(__name__).exception("ros_callback_failed")

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    try:
        yield Sim(node, client, context, action, amcl, odom, images, plans, infos, costmaps)
    finally:
        # stop spinning before anything is destroyed: a callback still running on a destroyed
        # action client or server raises in the spin thread ("destruction was requested")
        stopping.set()
        executor.shutdown(timeout_sec=10.0)
        spinner.join(timeout=10.0)
        action.destroy()
        node.destroy_node()
        client.destroy_node()
        rclpy.try_shutdown(context=context)
