"""ROS parameters go through the same Pydantic validation as the Hydra config (issue 13 item 5)
and camera_topic selects the subscribed topic (item 6)."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.frames import FrameListener, FrameSource
from robot_mcp_perception.settings import NodeSettings, StartupError, node_settings_with


def test_ros_parameters_override_the_hydra_node_settings() -> None:
    node = node_settings_with(
        NodeSettings(), {"camera_topic": "/cam_b/image_raw", "processing_frequency": 2}
    )
    assert node.camera_topic == "/cam_b/image_raw"
    assert node.processing_frequency == 2.0


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        ({"processing_frequency": 0}, r"processing_frequency: .*greater than 0"),
        ({"max_in_flight": 0}, r"max_in_flight"),
        ({"topic_namespace": "vision"}, r"topic_namespace"),
        ({"default_skills": "[{oops"}, r"default_skills is not valid JSON"),
        ({"default_skills": '{"name": "x"}'}, r"default_skills must be a JSON list"),
        (
            {"default_skills": '[{"name": "x", "mode": "dance"}]'},
            r"default_skills: .*skill 0: invalid_mode",
        ),
        (
            {"default_skills": json.dumps([{"name": "a", "mode": "describe"}] * 2)},
            r"duplicate skill name 'a'",
        ),
    ],
)
def test_bad_ros_parameters_are_one_clear_start_up_error(
    parameters: dict[str, Any], message: str
) -> None:
    with pytest.raises(StartupError, match=message) as caught:
        node_settings_with(NodeSettings(), parameters)
    assert "\n" not in str(caught.value)


def test_bad_default_skills_in_the_hydra_config_are_refused_too() -> None:
    with pytest.raises(ValueError, match="invalid_mode"):
        NodeSettings.model_validate({"default_skills": [{"name": "x", "mode": "dance"}]})


class SilentCamera(FrameSource):
    def start(self, node: Any, on_frame: FrameListener | None = None) -> None:
        self._listener = on_frame

    def stop(self) -> None:
        self._listener = None


@pytest.fixture
def ros_context() -> Iterator[Any]:
    import rclpy
    from rclpy.context import Context

    contexts: list[Any] = []

    def make(*ros_args: str) -> Any:
        context = Context()
        rclpy.init(args=["--ros-args", *ros_args], context=context)
        contexts.append(context)
        return context

    yield make
    for context in contexts:
        rclpy.shutdown(context=context)


@pytest.mark.ros
def test_an_out_of_range_ros_parameter_refuses_to_build_the_node(
    ros_context: Any, settings_factory: Any
) -> None:
    from robot_mcp_perception.models.fakes import FakeGrounder
    from robot_mcp_perception.models.null import NullSegmenter
    from robot_mcp_perception.pipelines import run_skill
    from robot_mcp_perception.runtime import Runtime
    from robot_mcp_perception.vision_node import VisionNode

    context = ros_context("-p", "processing_frequency:=0")
    runtime = Runtime(
        settings=settings_factory(),
        grounder=FakeGrounder(),
        segmenter=NullSegmenter(),
        frame_source=SilentCamera(),
        runner=run_skill,
        serve_artifacts=False,
    )
    with pytest.raises(StartupError, match="processing_frequency"):
        VisionNode(runtime, context=context)


@pytest.mark.ros
def test_the_camera_topic_parameter_selects_the_subscribed_topic(
    ros_context: Any, settings_factory: Any
) -> None:
    import rclpy
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Image as ImageMsg
    from std_msgs.msg import Header

    from robot_mcp_perception.conversions import rgb_to_image_msg
    from robot_mcp_perception.frames_ros import RosFrameSource
    from robot_mcp_perception.models.fakes import FakeGrounder
    from robot_mcp_perception.models.null import NullSegmenter
    from robot_mcp_perception.pipelines import run_skill
    from robot_mcp_perception.runtime import Runtime
    from robot_mcp_perception.vision_node import VisionNode

    context = ros_context("-p", "camera_topic:=/cam_b/image_raw")
    source = RosFrameSource(topic="/camera/image_raw")  # what Hydra's ${node.camera_topic} gave
    runtime = Runtime(
        settings=settings_factory(),
        grounder=FakeGrounder(),
        segmenter=NullSegmenter(),
        frame_source=source,
        runner=run_skill,
        serve_artifacts=False,
    )
    node = VisionNode(runtime, context=context)
    camera = rclpy.create_node("camera_b", context=context)
    executor = MultiThreadedExecutor(num_threads=2, context=context)
    executor.add_node(node)
    executor.add_node(camera)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        publisher = camera.create_publisher(ImageMsg, "/cam_b/image_raw", qos)
        image = np.full((24, 32, 3), 90, np.uint8)
        deadline = time.monotonic() + 10.0
        while source.latest() is None:
            assert time.monotonic() < deadline, "no frame from /cam_b/image_raw"
            header = Header(stamp=camera.get_clock().now().to_msg(), frame_id="cam_b")
            publisher.publish(rgb_to_image_msg(image, header))
            time.sleep(0.05)
        assert source.topic == "/cam_b/image_raw"
        assert camera.count_subscribers("/camera/image_raw") == 0
    finally:
        executor.shutdown(timeout_sec=2.0)
        thread.join(timeout=5.0)
        node.shutdown()
        node.destroy_node()
        camera.destroy_node()


@pytest.mark.ros
def test_a_stop_while_the_default_skills_are_created_is_a_quiet_normal_stop(
    settings_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    """SIGINT's handler shuts the ROS context down; a node still creating its start-up skills
    then stops as on any other stop (no traceback, no refusal to start: exit 0)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import ExternalShutdownException

    from robot_mcp_perception.models.fakes import FakeGrounder
    from robot_mcp_perception.models.null import NullSegmenter
    from robot_mcp_perception.pipelines import run_skill
    from robot_mcp_perception.runtime import Runtime
    from robot_mcp_perception.vision_node import VisionNode

    class StoppedWhileStarting(VisionNode):
        def _create_default_skills(self) -> None:
            rclpy.shutdown(context=self.context)  # what the SIGINT handler does
            super()._create_default_skills()

    context = Context()
    rclpy.init(context=context)
    runtime = Runtime(
        settings=settings_factory(node={"default_skills": [{"name": "scene", "mode": "describe"}]}),
        grounder=FakeGrounder(),
        segmenter=NullSegmenter(),
        frame_source=SilentCamera(),
        runner=run_skill,
        serve_artifacts=False,
    )
    try:
        with pytest.raises(ExternalShutdownException):
            StoppedWhileStarting(runtime, context=context)
    finally:
        rclpy.try_shutdown(context=context)
    events = [e["event"] for e in log_events]
    assert "vision_task_failed" not in events, log_events
    assert any(e.get("error") == "shutting_down" for e in log_events), log_events
