"""`make demo`: prove the ROS data path end to end on this machine and say what happened.

A separate OS process publishes a VisionDetectionArray carrying a 640x480 mono8 mask (a
manipulation consumer's view of /vision/find_object/detections); this process subscribes,
checks the mask byte for byte, and calls a VisionTask service served by a third process.
Discovery stays on loopback (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) in its own domain.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from ros2_vision_interfaces.msg import VisionDetectionArray
from ros2_vision_interfaces.srv import VisionTask

from robot_stack_testing import ProcessLauncher, ros_peers, wait_until

TOPIC = "/vision/find_object/detections"
SERVICE = "/demo/create_vision_task"


def main() -> int:
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    print(f"demo: ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID')} discovery=LOCALHOST")
    launcher = ProcessLauncher(Path(tempfile.mkdtemp(prefix="robot-demo-")))
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("demo_consumer", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    received: list[tuple[float, Any]] = []
    node.create_subscription(
        VisionDetectionArray, TOPIC, lambda m: received.append((time.monotonic(), m)), 10
    )
    peer = [sys.executable, "-m", "robot_stack_testing.ros_peers"]
    try:
        publisher = launcher.start("publisher", [*peer, "publish-mask", "--topic", TOPIC])
        server = launcher.start("server", [*peer, "serve-echo", "--name", SERVICE])
        started = time.monotonic()
        wait_until(lambda: received, 20.0, f"a message on {TOPIC}")
        arrived, array = received[0]
        detection = array.detections[0]
        mask = bytes(detection.mask.data)
        intact = ros_peers.mask_digest(mask) == ros_peers.mask_digest(ros_peers.sample_mask())
        print(
            f"demo: received {TOPIC} from publisher pid {publisher.pid} after "
            f"{arrived - started:.2f}s (incl. discovery): skill={array.skill} "
            f"label={detection.label!r} score={detection.score:.2f} "
            f"mask={detection.mask.width}x{detection.mask.height} {detection.mask.encoding} "
            f"({len(mask)} bytes, {'intact' if intact else 'CORRUPTED'}) "
            f"stamp={array.header.stamp.sec}.{array.header.stamp.nanosec:09d} "
            f"frame_id={array.header.frame_id}"
        )
        client: Any = node.create_client(VisionTask, SERVICE)
        wait_until(client.service_is_ready, 20.0, f"service {SERVICE}")
        request = VisionTask.Request()
        request.data = json.dumps({"name": "find_object", "mode": "ground_and_segment"})
        future = client.call_async(request)
        wait_until(future.done, 10.0, "the VisionTask response")
        response = future.result()
        if response is None:
            raise RuntimeError(f"{SERVICE} returned no response")
        print(
            f"demo: VisionTask call to {SERVICE} (pid {server.pid}) -> "
            f"success={response.success} message={response.message}"
        )
        ok = intact and response.success
        print("demo: ROS data path OK" if ok else "demo: ROS data path FAILED")
        return 0 if ok else 1
    finally:
        launcher.stop_all()
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=2.0)


if __name__ == "__main__":
    sys.exit(main())
