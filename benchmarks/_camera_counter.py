"""Counts robot-sim's camera frames (for ``sim_world.py``): published and received in a window,
and keeps the robot driving between far places; also the rates of its pose (``/amcl_pose``),
odometry (``/odom``) and NavigateToPose feedback in the same window (10 Hz each as configured:
the tests check the configuration, this measures what a loaded machine reaches).

"Published" are the ``/camera/camera_info`` messages (small, sent with every image under the
same stamp); "received" the images whose stamp is among them, by two readers in this process:
depth 1 (the camera's QoS, as the vision node reads it) and depth 10 (what the transport
delivered, even when this busy process spins late).
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from functools import partial
from typing import Any

import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import Odometry
from rclpy.action.client import ActionClient
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from sim_camera_vision import wait_for

from robot_sim.node import AMCL_QOS, CAMERA_QOS

FAR = ["meeting_room", "kitchen", "mailroom", "dock"]
READERS = {"depth1": 1, "depth10": 10}

Stamp = tuple[int, int]


def stamp_of(msg: Image | CameraInfo) -> Stamp:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


class CameraCounter:
    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("sim_world_bench", context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self.executor.add_node(self.node)
        self.infos: list[tuple[float, Stamp]] = []
        self.images: dict[str, list[Stamp]] = {name: [] for name in READERS}
        self.node.create_subscription(
            CameraInfo,
            "/camera/camera_info",
            lambda m: self.infos.append((time.monotonic(), stamp_of(m))),
            QoSProfile(
                depth=10, history=HistoryPolicy.KEEP_LAST, reliability=CAMERA_QOS.reliability
            ),
        )
        for name, depth in READERS.items():
            qos = QoSProfile(
                depth=depth,
                history=HistoryPolicy.KEEP_LAST,
                reliability=ReliabilityPolicy.BEST_EFFORT,
            )
            self.node.create_subscription(
                Image, "/camera/image_raw", partial(self._on_image, name), qos
            )
        self.arrivals: dict[str, list[float]] = {"pose": [], "odom": [], "nav_feedback": []}
        self.node.create_subscription(
            PoseWithCovarianceStamped, "/amcl_pose", lambda _m: self._arrived("pose"), AMCL_QOS
        )
        self.node.create_subscription(Odometry, "/odom", lambda _m: self._arrived("odom"), 10)
        self.navigate = ActionClient(self.node, NavigateToPose, "/navigate_to_pose")
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_image(self, reader: str, msg: Image) -> None:
        self.images[reader].append(stamp_of(msg))

    def _arrived(self, stream: str) -> None:
        self.arrivals[stream].append(time.monotonic())

    def window(self, t0: float, t1: float) -> dict[str, Any]:
        """Frames published in [t0, t1] and how many of them each reader received (fps)."""
        published = {s for t, s in self.infos if t0 <= t <= t1}
        seconds = t1 - t0
        counts: dict[str, Any] = {
            "frames_published": len(published),
            "camera_fps_published": round(len(published) / seconds, 2),
        }
        for name in READERS:
            received = len(published & set(self.images[name]))
            counts[f"frames_received_{name}"] = received
            counts[f"camera_fps_received_{name}"] = round(received / seconds, 2)
        for stream, times in self.arrivals.items():
            inside = [t for t in times if t0 <= t <= t1]
            gaps = [b - a for a, b in itertools.pairwise(inside)]
            counts[f"{stream}_hz"] = round(len(inside) / seconds, 2)
            counts[f"{stream}_gap_ms_max"] = round(1000 * max(gaps), 1) if gaps else None
        return counts

    def keep_driving(self, world: Any, until: float) -> None:
        """Goals between far places until ``until`` (the robot is always moving)."""
        if not self.navigate.wait_for_server(timeout_sec=30.0):
            raise TimeoutError("no NavigateToPose server")
        for name in itertools.cycle(FAR):
            if time.monotonic() > until:
                return
            place = world.map.locations[name]
            goal = NavigateToPose.Goal()
            goal.pose.header.frame_id = "map"
            goal.pose.pose.position.x, goal.pose.pose.position.y = place.x, place.y
            goal.pose.pose.orientation.z = math.sin(place.theta / 2)
            goal.pose.pose.orientation.w = math.cos(place.theta / 2)
            sent = self.navigate.send_goal_async(
                goal, feedback_callback=lambda _f: self._arrived("nav_feedback")
            )
            wait_for(sent.done, 10.0, "goal response")
            result = sent.result().get_result_async()
            wait_for(lambda r=result: r.done() or time.monotonic() > until, 120.0, "arrival")
            if not result.done():
                sent.result().cancel_goal_async()
                return

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
