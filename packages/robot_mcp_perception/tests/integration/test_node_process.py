"""The vision node as a real OS process, consumed from another process (spec 000 §10).

This test process plays the manipulation stand-in: it subscribes ``/vision/{skill}/detections``
and uses the mask, reads ``/detections_meta``, fetches the mask by its ``mask_ref`` url, and
checks from the ROS graph that ``delete`` removed the skill's publishers.
"""

from __future__ import annotations

import json
import shutil
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

from robot_mcp_perception.composition import default_config_dir
from robot_mcp_perception.sample_scenes import generate_scenes
from robot_stack_testing import ProcessLauncher, wait_for_tcp_port, wait_until

pytestmark = [pytest.mark.ros, pytest.mark.slow]


ARTIFACTS_TOKEN = "artifacts-credential-of-the-node-process-test"


@pytest.fixture
def node_env(tmp_path: Path, tcp_port: int) -> dict[str, str]:
    frames = tmp_path / "scenes"
    generate_scenes(frames, count=2, seed=3)
    config = tmp_path / "config"
    shutil.copytree(default_config_dir(), config)
    (config / "grounder").mkdir(exist_ok=True)
    (config / "segmenter").mkdir(exist_ok=True)
    (config / "grounder" / "it_annotation.yaml").write_text(
        "_target_: robot_mcp_perception.models.annotation.AnnotationGrounder\n"
        "cost_class: local\ndirectory: ${frame_source.directory}\n"
    )
    (config / "segmenter" / "it_none.yaml").write_text(
        "_target_: robot_mcp_perception.models.null.NullSegmenter\ncost_class: local\n"
    )
    return {
        "ARTIFACTS_AUTH_TOKEN": ARTIFACTS_TOKEN,
        "PERCEPTION_CONFIG_DIR": str(config),
        "PERCEPTION_CONFIG_OVERRIDES": (
            f"grounder=it_annotation segmenter=it_none frame_source=folder "
            f"frame_source.directory={frames} frame_source.fps=4 artifacts.port={tcp_port} "
            "node.default_skills.0.rate_hz=2"
        ),
    }


class Consumer:
    """rclpy node of the stand-in process (its own context, spun in a thread)."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("manipulation_stand_in", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self.lock = threading.Lock()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def subscribe(self, topic: str, msg_type: Any) -> list[Any]:
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        received: list[Any] = []
        qos = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(msg_type, topic, received.append, qos)
        return received

    def call(self, service: str, payload: dict[str, Any]) -> tuple[bool, dict[str, Any]]:
        from ros2_vision_interfaces.srv import VisionTask

        client = self.node.create_client(VisionTask, f"/vision_node/{service}")
        assert client.wait_for_service(timeout_sec=15.0), f"{service} never appeared"
        done = threading.Event()
        future = client.call_async(VisionTask.Request(data=json.dumps(payload)))
        future.add_done_callback(lambda _: done.set())
        assert done.wait(15.0), f"{service} did not answer"
        response = future.result()
        return bool(response.success), json.loads(response.message)

    def topics(self) -> set[str]:
        return {name for name, _ in self.node.get_topic_names_and_types()}

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self._thread.join(timeout=5.0)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def consumer() -> Iterator[Consumer]:
    stand_in = Consumer()
    yield stand_in
    stand_in.close()


def test_a_separate_process_gets_usable_masks_meta_and_scene_outputs_then_delete_clears_the_graph(
    launcher: ProcessLauncher, node_env: dict[str, str], tcp_port: int, consumer: Consumer
) -> None:
    from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

    from robot_mcp_perception.conversions import mask_from_image_msg

    process = launcher.start(
        "vision_node", [sys.executable, "-m", "robot_mcp_perception.vision_node"], env=node_env
    )
    wait_for_tcp_port(tcp_port, 30.0)
    healthz = f"http://127.0.0.1:{tcp_port}/healthz"
    wait_until(lambda: httpx.get(healthz, timeout=5.0).status_code == 200, 30.0, "healthy")
    health = httpx.get(healthz, timeout=5.0).json()
    assert health["status"] == "ok"
    assert health["skills"][0]["name"] == "scene"
    scene_text = consumer.subscribe("/vision/scene/scene_description", StampedString)
    detections = consumer.subscribe("/vision/everything/detections", VisionDetectionArray)
    meta = consumer.subscribe("/vision/everything/detections_meta", VisionDetectionArray)

    ok, reply = consumer.call(
        "create_vision_task",
        {"name": "everything", "mode": "segment_all", "segment": True, "rate_hz": 2.0},
    )
    assert ok, reply
    wait_until(lambda: any(m.detections for m in detections), 30.0, "detections with masks")
    wait_until(lambda: any(m.detections for m in meta), 30.0, "detections_meta")
    wait_until(lambda: scene_text, 30.0, "the scene description", interval_s=0.1)

    array = next(m for m in detections if m.detections)
    mask_msg = array.detections[0].mask
    mask = mask_from_image_msg(mask_msg)
    assert mask_msg.encoding == "mono8"
    assert mask.shape == (480, 640)
    assert 0 < int(np.count_nonzero(mask)) < mask.size
    assert array.header.frame_id == "camera"
    same = next(m for m in meta if m.header.stamp == array.header.stamp)
    assert [d.label for d in same.detections] == [d.label for d in array.detections]
    assert all(len(d.mask.data) == 0 for d in same.detections)
    ref = json.loads(array.detections[0].extra)["mask_ref"]
    png = httpx.get(ref["url"], timeout=5.0, headers={"Authorization": f"Bearer {ARTIFACTS_TOKEN}"})
    refused = httpx.get(ref["url"], timeout=5.0)  # any other local process: no picture
    assert refused.status_code == 401, refused.text
    assert refused.headers["www-authenticate"].startswith("Bearer")
    assert png.status_code == 200
    assert png.headers["content-type"] == "image/png"
    assert json.loads(scene_text[0].data)

    assert consumer.node.count_publishers("/vision/everything/detections") == 1
    ok, reply = consumer.call("manage_vision_task", {"task_name": "everything", "action": "delete"})
    assert ok, reply
    gone = ("/vision/everything/detections", "/vision/everything/detections_meta")
    wait_until(
        lambda: all(consumer.node.count_publishers(topic) == 0 for topic in gone),
        15.0,
        "the skill's publishers to leave the graph",
    )
    assert process.running(), process.log()


def test_node_process_refuses_to_start_without_the_frame_folder(
    launcher: ProcessLauncher, node_env: dict[str, str], tmp_path: Path
) -> None:
    env = {**node_env}
    env["PERCEPTION_CONFIG_OVERRIDES"] += f" frame_source.directory={tmp_path / 'missing'}"

    process = launcher.start(
        "vision_node", [sys.executable, "-m", "robot_mcp_perception.vision_node"], env=env
    )
    wait_until(lambda: not process.running(), 30.0, "the node to exit")

    assert process.popen.returncode == 2
    assert "sample_scenes" in process.log()


def _refusal(process: Any) -> list[str]:
    """The lines that say why the node refused (start-up info logs aside)."""
    wait_until(lambda: not process.running(), 60.0, "the node to exit")
    log = process.log()
    assert process.popen.returncode == 2, log
    assert "Traceback" not in log
    assert '"level": "error"' not in log
    return [line for line in log.splitlines() if line.startswith("vision_node")]


@pytest.mark.parametrize(
    ("ros_args", "named"),
    [
        (["-p", "processing_frequency:=0"], "processing_frequency"),
        (["-p", "default_skills:='[{oops'"], "default_skills is not valid JSON"),
        (["-p", "default_skills:=[{oops"], "cannot parse the ROS arguments"),
    ],
)
def test_a_bad_ros_parameter_exits_2_with_one_line_naming_it(
    launcher: ProcessLauncher, node_env: dict[str, str], ros_args: list[str], named: str
) -> None:
    argv = [sys.executable, "-m", "robot_mcp_perception.vision_node", "--ros-args", *ros_args]
    lines = _refusal(launcher.start("vision_node", argv, env=node_env))

    assert len(lines) == 1, lines
    assert lines[0].startswith("vision_node: ")
    assert named in lines[0]


def test_a_busy_artifacts_port_exits_2_with_one_line_naming_it(
    launcher: ProcessLauncher, node_env: dict[str, str], tcp_port: int
) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", tcp_port))
        busy.listen()
        argv = [sys.executable, "-m", "robot_mcp_perception.vision_node"]
        lines = _refusal(launcher.start("vision_node", argv, env=node_env))

    assert len(lines) == 1, lines
    assert f"artifacts port 127.0.0.1:{tcp_port}" in lines[0]
