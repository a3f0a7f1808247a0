"""robot-sim camera → vision node result (issue 19): the local stack's real-robot data path.

Real OS processes: ``robot-sim`` (time scale 20) and ``vision_node`` on ``frame_source=ros``
(offline grounder on the sim's scenes folder, GrabCut). This process drives the robot to the
kitchen through ``NavigateToPose``, creates a continuous find_object skill ("the red mug",
5 Hz, the camera's rate) and for ``--seconds`` records, per result on
``/vision/find_object/detections``, receive wall time − the source frame's header stamp (the
sim stamps each frame as it publishes it): camera topic (rgb8 640×480, 5 fps) → result.
Also: the camera topic's own delivery latency and rate seen here, and the CPU (% of one core)
of robot-sim and of the vision node over the window. Both processes run with the local
stack's environment (``deploy/local-stack.yaml``'s ``env:``: the Fast DDS profile that carries
the frames over shared memory); ``--no-fastdds-profile`` leaves it out. Bounded: < 2 min with
defaults.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 199)))
# a profile from the shell (a robot's) never reaches the processes started here: only the stack's
os.environ.pop("FASTDDS_DEFAULT_PROFILES_FILE", None)
os.environ.pop("FASTRTPS_DEFAULT_PROFILES_FILE", None)

import rclpy
from nav2_msgs.action import NavigateToPose
from rclpy.action.client import ActionClient
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros2_vision_interfaces.msg import VisionDetectionArray
from ros2_vision_interfaces.srv import VisionTask
from sensor_msgs.msg import Image

from robot_stack_testing.stack import stack_environment

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
CAMERA_QOS = QoSProfile(
    depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.BEST_EFFORT
)
TICKS = os.sysconf("SC_CLK_TCK")


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS  # utime + stime


def wait_for(check: Any, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not check():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out waiting for {what}")
        time.sleep(0.05)


def stack_env(var: Path) -> dict[str, str]:
    """What every service of the local stack gets (its Fast DDS profile)."""
    substitutions = {"python": sys.executable, "root": str(ROOT), "var": str(var)}
    return stack_environment(ROOT / "deploy" / "local-stack.yaml", substitutions)


def start(argv: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    with log.open("wb") as out:
        return subprocess.Popen(
            argv, env={**os.environ, **env}, stdout=out, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
        )  # fmt: skip


def stop(process: subprocess.Popen[bytes]) -> None:
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=10.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=5.0)


class Client:
    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("sim_camera_bench", context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        self.create = self.node.create_client(VisionTask, "/vision_node/create_vision_task")
        self.navigate = ActionClient(self.node, NavigateToPose, "/navigate_to_pose")
        self.results: list[float] = []
        self.camera: list[tuple[float, float]] = []
        self.recording = False
        self.node.create_subscription(
            VisionDetectionArray, "/vision/find_object/detections", self._on_result, 10
        )
        self.node.create_subscription(Image, "/camera/image_raw", self._on_image, CAMERA_QOS)

    @staticmethod
    def _age_ms(stamp: Any) -> float:
        return (time.time_ns() - (stamp.sec * 1_000_000_000 + stamp.nanosec)) / 1e6

    def _on_result(self, msg: VisionDetectionArray) -> None:
        if self.recording and msg.detections:
            self.results.append(self._age_ms(msg.header.stamp))

    def _on_image(self, msg: Image) -> None:
        if self.recording:
            self.camera.append((time.monotonic(), self._age_ms(msg.header.stamp)))

    def drive_to(self, x: float, y: float) -> None:
        if not self.navigate.wait_for_server(timeout_sec=30.0):
            raise TimeoutError("no NavigateToPose server")
        goal = NavigateToPose.Goal()
        goal.pose.header.frame_id = "map"
        goal.pose.pose.position.x, goal.pose.pose.position.y = x, y
        goal.pose.pose.orientation.w = 1.0
        sent = self.navigate.send_goal_async(goal)
        wait_for(sent.done, 10.0, "goal response")
        result = sent.result().get_result_async()
        wait_for(result.done, 60.0, "arrival")

    def create_skill(self, skill: dict[str, Any]) -> None:
        if not self.create.wait_for_service(timeout_sec=30.0):
            raise TimeoutError("create_vision_task never appeared")
        future = self.create.call_async(VisionTask.Request(data=json.dumps(skill)))
        wait_for(future.done, 15.0, "create_vision_task")
        if not future.result().success:
            raise RuntimeError(future.result().message)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--no-fastdds-profile", action="store_true")
    args = parser.parse_args()
    load_at_start = Path("/proc/loadavg").read_text().split()[:3]
    work = Path(tempfile.mkdtemp(prefix="sim_camera_bench_"))
    scenes, ready, port = work / "scenes", work / "sim.pid", free_port()
    common = {} if args.no_fastdds_profile else stack_env(work)
    sim = start(
        [sys.executable, "-m", "robot_sim"],
        {
            **common,
            "SIM_SCENES_DIR": str(scenes),
            "SIM_READY_FILE": str(ready),
            "SIM_TIME_SCALE": "20",
        },
        work / "robot_sim.log",
    )
    vision: subprocess.Popen[bytes] | None = None
    client: Client | None = None
    try:
        wait_for(lambda: ready.is_file() and ready.read_text() == str(sim.pid), 60, "robot-sim")
        vision = start(
            [sys.executable, "-m", "robot_mcp_perception.vision_node"],
            {
                **common,
                "PERCEPTION_DEPLOYMENT": "",
                "PERCEPTION_CONFIG_DIR": "",
                "PERCEPTION_CONFIG_OVERRIDES": (
                    f"frame_source=ros grounder.directory={scenes} artifacts.port={port}"
                ),
            },
            work / "vision_node.log",
        )
        client = Client()
        client.drive_to(9.0, -3.0)  # the kitchen: the red mug is in view
        client.create_skill(
            {"name": "find_object", "mode": "ground_and_segment", "grounding": "the red mug",
             "segment": True, "rate_hz": 5.0}
        )  # fmt: skip
        client.recording = True
        wait_for(lambda: client is not None and len(client.results) > 0, 30, "a first result")
        client.results.clear()
        client.camera.clear()
        sim_cpu0, vision_cpu0, t0 = cpu_s(sim.pid), cpu_s(vision.pid), time.monotonic()
        deadline = t0 + args.seconds
        while time.monotonic() < deadline:
            time.sleep(0.5)
        window = time.monotonic() - t0
        sim_cpu = (cpu_s(sim.pid) - sim_cpu0) / window * 100
        vision_cpu = (cpu_s(vision.pid) - vision_cpu0) / window * 100
        client.recording = False
        results, camera = list(client.results), list(client.camera)
    finally:
        if client is not None:
            client.close()
        if vision is not None:
            stop(vision)
        stop(sim)

    camera_ages = [age for _, age in camera]
    result = {
        "what": "robot-sim /camera/image_raw (rgb8 640x480, 5 fps) -> vision node find_object "
        "result (frame_source=ros, offline grounder on the sim's scenes, GrabCut)",
        "seconds": round(window, 1),
        "results": len(results),
        "result_latency_ms": {
            "p50": round(percentile(results, 50), 1),
            "p90": round(percentile(results, 90), 1),
            "p99": round(percentile(results, 99), 1),
            "max": round(max(results), 1),
        },
        "fastdds_profile": common.get("FASTDDS_DEFAULT_PROFILES_FILE"),
        "camera_frames_received": len(camera),
        "camera_fps_received": round(len(camera) / window, 2),
        "camera_delivery_ms": {
            "p50": round(percentile(camera_ages, 50), 1),
            "p99": round(percentile(camera_ages, 99), 1),
        },
        "cpu_percent_of_one_core": {
            "robot_sim": round(sim_cpu, 1),
            "vision_node": round(vision_cpu, 1),
        },
        "loadavg_at_start": load_at_start,
        "loadavg_at_end": Path("/proc/loadavg").read_text().split()[:3],
    }
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "sim_camera_vision.json"
    out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
