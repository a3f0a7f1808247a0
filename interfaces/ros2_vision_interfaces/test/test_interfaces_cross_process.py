"""ros2_vision_interfaces crosses OS processes intact (loopback discovery, own domain id)."""

from __future__ import annotations

import json
import sys
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray
from ros2_vision_interfaces.srv import VisionTask

from robot_stack_testing import ProcessLauncher, ros_peers, wait_until

pytestmark = pytest.mark.ros


@pytest.fixture
def node() -> Iterator[Node]:
    context = Context()
    rclpy.init(context=context)
    test_node = rclpy.create_node("interfaces_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(test_node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        yield test_node
    finally:
        executor.shutdown(timeout_sec=2.0)
        test_node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=2.0)


def peer_argv(*args: str) -> list[str]:
    return [sys.executable, "-m", "robot_stack_testing.ros_peers", *args]


def test_detection_array_with_full_frame_mask_arrives_intact_in_another_process(
    node: Node, launcher: ProcessLauncher
) -> None:
    received: list[Any] = []
    node.create_subscription(
        VisionDetectionArray, "/vision/find_object/detections", received.append, 10
    )
    launcher.start("publisher", peer_argv("publish-mask", "--seconds", "30"))

    wait_until(lambda: received, 20.0, "a VisionDetectionArray from the publisher process")

    array = received[0]
    assert array.skill == "find_object"
    assert array.header.frame_id == ros_peers.FRAME_ID
    assert (array.header.stamp.sec, array.header.stamp.nanosec) == (
        ros_peers.STAMP_SEC,
        ros_peers.STAMP_NANOSEC,
    )
    mask = array.detections[0].mask
    assert (mask.width, mask.height, mask.encoding, mask.step) == (640, 480, "mono8", 640)
    assert ros_peers.mask_digest(bytes(mask.data)) == ros_peers.mask_digest(ros_peers.sample_mask())
    assert array.detections[0].label == "scissors"
    assert json.loads(array.detections[0].extra) == {"source": "ros_peers"}


def test_vision_task_call_crosses_processes(node: Node, launcher: ProcessLauncher) -> None:
    launcher.start("server", peer_argv("serve-echo", "--name", "/peer/create_vision_task"))
    client: Any = node.create_client(VisionTask, "/peer/create_vision_task")
    wait_until(lambda: client.service_is_ready(), 20.0, "the VisionTask service in the peer")

    request = VisionTask.Request()
    request.data = json.dumps({"name": "scene", "mode": "describe"})
    future = client.call_async(request)
    wait_until(future.done, 10.0, "the VisionTask response")

    response = future.result()
    assert response is not None
    assert response.success is True
    assert json.loads(response.message) == {"echo": {"name": "scene", "mode": "describe"}}


def test_stamped_string_keeps_header_and_json_payload() -> None:
    message = StampedString()
    message.header.frame_id = "cam"
    message.header.stamp.sec = 42
    message.data = json.dumps(["cup", "box"])
    assert json.loads(message.data) == ["cup", "box"]
    assert (message.header.frame_id, message.header.stamp.sec) == ("cam", 42)
