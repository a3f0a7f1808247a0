"""find_object one-shot latency (issue 4): ``create_vision_task`` → first ``/detections`` message.

A real ``vision_node`` OS process with the offline defaults (annotation grounder, GrabCut,
folder frames over the generated scenes that show the object); only the frame folder and the
artifacts port are set.
This process creates N ``once: true`` find_object skills one after the other (unique names,
each deleted after its result) and times, per skill, from the create call to the first
message on ``/vision/<name>/detections`` received here. That includes the service round trip,
the node's pick-up, grounding, GrabCut, publishing and DDS endpoint matching of the new topic
— what a one-shot client sees. Bounded: < 2 min.
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

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros2_vision_interfaces.msg import VisionDetectionArray
from ros2_vision_interfaces.srv import VisionTask

from robot_mcp_perception.sample_scenes import generate_scenes

RESULTS = Path(__file__).resolve().parent / "results"
RESULT_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def wait_for_port(port: int, process: subprocess.Popen[bytes], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"vision_node exited with {process.returncode}")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.1)
    raise TimeoutError(f"vision_node did not listen on {port} within {timeout_s} s")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


class Client:
    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("find_object_bench", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self.create = self.node.create_client(VisionTask, "/vision_node/create_vision_task")
        self.manage = self.node.create_client(VisionTask, "/vision_node/manage_vision_task")

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.01)

    def call(self, client: Any, payload: dict[str, Any], timeout_s: float = 10.0) -> Any:
        done = threading.Event()
        future = client.call_async(VisionTask.Request(data=json.dumps(payload)))
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s):
            client.remove_pending_request(future)
            raise TimeoutError(f"no reply within {timeout_s} s")
        response = future.result()
        if not response.success:
            raise RuntimeError(response.message)
        return response

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--label", default="red mug", help="ground 'the <label>'")
    parser.add_argument("--timeout", type=float, default=10.0, help="per run, seconds")
    args = parser.parse_args()

    started = time.monotonic()
    load_at_start = Path("/proc/loadavg").read_text().split()[:3]
    frames = Path(tempfile.mkdtemp(prefix="find_object_bench_"))
    for png in generate_scenes(frames, count=8, seed=0):  # keep the scenes with the object
        labels = {
            a["label"] for a in json.loads(png.with_suffix(".json").read_text())["annotations"]
        }
        if args.label not in labels:
            png.unlink()
            png.with_suffix(".json").unlink()
    port = free_port()
    env = {
        **os.environ,
        "PERCEPTION_DEPLOYMENT": "",
        "PERCEPTION_CONFIG_DIR": "",
        "PERCEPTION_CONFIG_OVERRIDES": f"frame_source.directory={frames} artifacts.port={port}",
    }
    log_path = frames / "vision_node.log"
    with log_path.open("wb") as log:
        process = subprocess.Popen(
            [sys.executable, "-m", "robot_mcp_perception.vision_node"],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
        )
    client: Client | None = None
    create_ms: list[float] = []
    first_ms: list[float] = []
    with_target = 0
    try:
        wait_for_port(port, process, 30.0)
        client = Client()
        if not client.create.wait_for_service(timeout_sec=15.0):
            raise TimeoutError("create_vision_task never appeared")
        client.manage.wait_for_service(timeout_sec=15.0)
        for index in range(args.runs):
            name = f"find_object_{index:02d}"
            arrived = threading.Event()
            received: list[tuple[float, VisionDetectionArray]] = []

            def on_message(
                msg: VisionDetectionArray,
                box: list[Any] = received,
                done: threading.Event = arrived,
            ) -> None:
                if not box:
                    box.append((time.perf_counter(), msg))
                    done.set()

            subscription = client.node.create_subscription(
                VisionDetectionArray, f"/vision/{name}/detections", on_message, RESULT_QOS
            )
            skill = {
                "name": name,
                "mode": "ground_and_segment",
                "grounding": f"the {args.label}",
                "segment": True,
                "once": True,
            }
            t0 = time.perf_counter()
            client.call(client.create, skill)
            t_created = time.perf_counter()
            if not arrived.wait(args.timeout):
                raise TimeoutError(f"{name}: no /detections within {args.timeout} s")
            t_first, msg = received[0]
            create_ms.append((t_created - t0) * 1e3)
            first_ms.append((t_first - t0) * 1e3)
            with_target += bool(msg.detections)
            client.call(client.manage, {"task_name": name, "action": "delete"})
            client.node.destroy_subscription(subscription)
    finally:
        if client is not None:
            client.close()
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=5.0)

    result = {
        "what": "find_object one-shot: create_vision_task -> first /detections message",
        "defaults": "offline (annotation grounder, GrabCut segmenter, folder frames @ 2 fps)",
        "runs": len(first_ms),
        "grounding": f"the {args.label}",
        "scenes": len(list(frames.glob("*.png"))),
        "results_with_the_object": with_target,
        "first_detections_ms_p50": round(percentile(first_ms, 50), 1),
        "first_detections_ms_p90": round(percentile(first_ms, 90), 1),
        "first_detections_ms_max": round(max(first_ms), 1),
        "create_call_ms_p50": round(percentile(create_ms, 50), 1),
        "samples_ms": [round(v, 1) for v in first_ms],
        "loadavg_start": load_at_start,
        "loadavg_end": Path("/proc/loadavg").read_text().split()[:3],
        "cpu_count": os.cpu_count(),
        "wall_s": round(time.monotonic() - started, 1),
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / "perception_find_object_oneshot.json"
    path.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    print(f"written to {path}")


if __name__ == "__main__":
    main()
