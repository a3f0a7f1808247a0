"""Stand-alone ROS peers run as separate OS processes by tests and the smoke demo.

``python -m robot_stack_testing.ros_peers publish-mask --topic T --seconds S`` publishes a
VisionDetectionArray carrying a deterministic 640x480 mono8 mask; ``serve-echo --name N``
serves a VisionTask service that answers ``{"echo": <request JSON>}``. Both exit by
themselves after ``--seconds``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from typing import Any

import numpy as np

MASK_WIDTH = 640
MASK_HEIGHT = 480
FRAME_ID = "camera_color_optical_frame"
STAMP_SEC = 1_700_000_000
STAMP_NANOSEC = 123_456_789


def sample_mask() -> bytes:
    """A deterministic mono8 mask (0/255): a filled ellipse plus a seeded speckle pattern."""
    yy, xx = np.mgrid[0:MASK_HEIGHT, 0:MASK_WIDTH]
    ellipse = ((xx - 320) / 150.0) ** 2 + ((yy - 240) / 90.0) ** 2 <= 1.0
    speckle = np.random.default_rng(7).random((MASK_HEIGHT, MASK_WIDTH)) > 0.97
    return (np.where(ellipse | speckle, 255, 0).astype(np.uint8)).tobytes()


def mask_digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def build_detection_array(skill: str = "find_object") -> Any:
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

    detection = VisionDetection()
    detection.label = "scissors"
    detection.score = 0.87
    detection.kind = "object"
    detection.box.x_offset, detection.box.y_offset = 170, 150
    detection.box.width, detection.box.height = 300, 180
    detection.mask.height, detection.mask.width = MASK_HEIGHT, MASK_WIDTH
    detection.mask.encoding = "mono8"
    detection.mask.step = MASK_WIDTH
    detection.mask.data = sample_mask()
    detection.point.x, detection.point.y = 320.0, 240.0
    detection.extra = json.dumps({"source": "ros_peers"})

    array = VisionDetectionArray()
    array.header.stamp.sec = STAMP_SEC
    array.header.stamp.nanosec = STAMP_NANOSEC
    array.header.frame_id = FRAME_ID
    array.skill = skill
    array.detections = [detection]
    return array


def publish_mask(topic: str, seconds: float, rate_hz: float) -> None:
    import rclpy
    from ros2_vision_interfaces.msg import VisionDetectionArray

    rclpy.init()
    node = rclpy.create_node("ros_peers_mask_publisher")
    try:
        publisher = node.create_publisher(VisionDetectionArray, topic, 10)
        message = build_detection_array()
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            publisher.publish(message)
            rclpy.spin_once(node, timeout_sec=1.0 / rate_hz)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def serve_echo(name: str, seconds: float) -> None:
    import rclpy
    from ros2_vision_interfaces.srv import VisionTask

    def handle(request: Any, response: Any) -> Any:
        try:
            response.message = json.dumps({"echo": json.loads(request.data)})
            response.success = True
        except json.JSONDecodeError as error:
            response.success = False
            response.message = json.dumps({"error": "invalid_json", "detail": str(error)})
        return response

    rclpy.init()
    node = rclpy.create_node("ros_peers_echo_server")
    try:
        node.create_service(VisionTask, name, handle)
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="ros_peers", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    publish = commands.add_parser("publish-mask")
    publish.add_argument("--topic", default="/vision/find_object/detections")
    publish.add_argument("--seconds", type=float, default=20.0)
    publish.add_argument("--rate-hz", type=float, default=10.0)
    serve = commands.add_parser("serve-echo")
    serve.add_argument("--name", default="/ros_peers/echo")
    serve.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args(argv)
    if args.command == "publish-mask":
        publish_mask(args.topic, args.seconds, args.rate_hz)
    else:
        serve_echo(args.name, args.seconds)


if __name__ == "__main__":
    main()
