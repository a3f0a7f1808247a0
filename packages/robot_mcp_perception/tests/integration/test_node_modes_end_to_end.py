"""The four skill modes end to end through the running node, with the offline defaults.

One ``vision_node`` OS process (annotation grounder, GrabCut segmenter, folder frames) plays
a generated scene; this test process creates one skill per mode over ``VisionTask`` and
scores what the node publishes against the scene's annotation (issue 4).
"""

from __future__ import annotations

import json
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.sample_scenes import generate_scenes, polygon_mask
from robot_stack_testing import ProcessLauncher, free_tcp_port, wait_for_tcp_port, wait_until

pytestmark = [pytest.mark.ros, pytest.mark.slow]

WIDTH, HEIGHT = 640, 480
WAIT_S = 30.0


@dataclass(frozen=True)
class Scene:
    description: str
    labels: list[str]
    masks: list[np.ndarray[Any, Any]]
    boxes: list[tuple[int, int, int, int]]
    """Annotation bboxes as xyxy (inclusive right/bottom edge)."""


class Client:
    """The test process's own rclpy node (fresh Context), spun in a thread."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("modes_end_to_end_client", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def subscribe(self, topic: str, msg_type: Any) -> list[Any]:
        """RELIABLE + TRANSIENT_LOCAL, like the node's per-skill topics."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        received: list[Any] = []
        qos = QoSProfile(
            depth=5,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )

        def record(msg: Any) -> None:
            with self._lock:
                received.append(msg)

        self.node.create_subscription(msg_type, topic, record, qos)
        return received

    def create_skill(self, skill: dict[str, Any]) -> dict[str, Any]:
        from ros2_vision_interfaces.srv import VisionTask

        client = self.node.create_client(VisionTask, "/vision_node/create_vision_task")
        assert client.wait_for_service(timeout_sec=WAIT_S), "create_vision_task never appeared"
        done = threading.Event()
        future = client.call_async(VisionTask.Request(data=json.dumps(skill)))
        future.add_done_callback(lambda _: done.set())
        assert done.wait(15.0), "create_vision_task did not answer"
        response = future.result()
        reply: dict[str, Any] = json.loads(response.message)
        assert response.success, reply
        return reply

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self._thread.join(timeout=5.0)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Scene]:
    frames = tmp_path_factory.mktemp("scenes")
    (png,) = generate_scenes(frames, count=1, seed=0)
    doc = json.loads(png.with_suffix(".json").read_text())
    annotations = doc["annotations"]
    return frames, Scene(
        description=doc["description"],
        labels=[a["label"] for a in annotations],
        masks=[polygon_mask(a["segmentation"], WIDTH, HEIGHT) for a in annotations],
        boxes=[(x, y, x + w - 1, y + h - 1) for x, y, w, h in (a["bbox"] for a in annotations)],
    )


@pytest.fixture(scope="module")
def node(
    scene: tuple[Path, Scene], tmp_path_factory: pytest.TempPathFactory
) -> Iterator[ProcessLauncher]:
    """One vision_node process (offline defaults: only the folder and the port are set)."""
    frames, _ = scene
    port = free_tcp_port()
    launcher = ProcessLauncher(tmp_path_factory.mktemp("processes"))
    env = {
        "PERCEPTION_DEPLOYMENT": "",
        "PERCEPTION_CONFIG_DIR": "",
        "PERCEPTION_CONFIG_OVERRIDES": f"frame_source.directory={frames} artifacts.port={port}",
    }
    process = launcher.start(
        "vision_node", [sys.executable, "-m", "robot_mcp_perception.vision_node"], env=env
    )
    try:
        wait_for_tcp_port(port, WAIT_S)
        assert process.running(), process.log()
        yield launcher
        assert process.running(), process.log()
    finally:
        launcher.stop_all()


@pytest.fixture(scope="module")
def client(node: ProcessLauncher) -> Iterator[Client]:
    peer = Client()
    yield peer
    peer.close()


def iou(a: np.ndarray[Any, Any], b: np.ndarray[Any, Any]) -> float:
    union = int(np.count_nonzero(a | b))
    return int(np.count_nonzero(a & b)) / union if union else 0.0


def xyxy(detection: Any) -> tuple[int, int, int, int]:
    box = detection.box
    return (
        box.x_offset,
        box.y_offset,
        box.x_offset + box.width,
        box.y_offset + box.height,
    )


def first_result(messages: list[Any], what: str) -> Any:
    wait_until(lambda: messages, WAIT_S, what, interval_s=0.05)
    return messages[0]


def test_ground_and_segment_publishes_the_named_objects_mask_and_a_point_on_it(
    client: Client, scene: tuple[Path, Scene]
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    from robot_mcp_perception.conversions import mask_from_image_msg

    _, truth = scene
    target = truth.labels.index("red mug")
    received = client.subscribe("/vision/find_mug/detections", VisionDetectionArray)
    reply = client.create_skill(
        {
            "name": "find_mug",
            "mode": "ground_and_segment",
            "grounding": "the red mug",
            "segment": True,
            "once": True,
        }
    )

    array = first_result(received, "the find_mug detections")
    assert reply["topics"]["detections"] == "/vision/find_mug/detections"
    assert array.skill == "find_mug"
    assert array.header.frame_id == "camera"
    assert [d.label for d in array.detections] == ["red mug"]
    detection = array.detections[0]
    assert detection.kind == "object"
    assert detection.mask.encoding == "mono8"
    mask = mask_from_image_msg(detection.mask)
    assert mask.shape == (HEIGHT, WIDTH)
    assert iou(mask, truth.masks[target]) >= 0.8
    x0, y0, x1, y1 = xyxy(detection)
    px, py = int(detection.point.x), int(detection.point.y)
    assert x0 <= px <= x1
    assert y0 <= py <= y1
    assert truth.masks[target][py, px]
    assert json.loads(detection.extra)["mask_ref"]["topic"] == "/vision/find_mug/detections"


def test_segment_all_publishes_one_matching_mask_per_annotated_instance(
    client: Client, scene: tuple[Path, Scene]
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    from robot_mcp_perception.conversions import mask_from_image_msg

    _, truth = scene
    received = client.subscribe("/vision/everything/detections", VisionDetectionArray)
    client.create_skill({"name": "everything", "mode": "segment_all", "once": True})

    array = first_result(received, "the segment_all detections")
    masks = [mask_from_image_msg(d.mask) for d in array.detections]
    matched: dict[int, int] = {}
    for index, mask in enumerate(masks):
        scores = [iou(mask, gt) for gt in truth.masks]
        best = int(np.argmax(scores))
        assert scores[best] >= 0.5, (array.detections[index].label, scores)
        assert best not in matched, f"two detections for annotation {truth.labels[best]!r}"
        matched[best] = index
    precision = len(matched) / len(masks)
    recall = len(matched) / len(truth.masks)
    assert (precision, recall) == (1.0, 1.0)
    assert sorted(d.label for d in array.detections) == sorted(truth.labels)


def test_region_publishes_free_space_clear_of_every_object_with_its_anchor(
    client: Client, scene: tuple[Path, Scene]
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    _, truth = scene
    received = client.subscribe("/vision/put_here/detections", VisionDetectionArray)
    client.create_skill(
        {
            "name": "put_here",
            "mode": "region",
            "grounding": "free flat space large enough for the package",
            "once": True,
        }
    )

    array = first_result(received, "the region detection")
    assert len(array.detections) == 1
    region = array.detections[0]
    assert region.kind == "region"
    assert len(region.mask.data) == 0
    x0, y0, x1, y1 = xyxy(region)
    assert 0 <= x0 < x1 <= WIDTH
    assert 0 <= y0 < y1 <= HEIGHT
    assert (x1 - x0) * (y1 - y0) > 0.05 * WIDTH * HEIGHT
    free = np.zeros((HEIGHT, WIDTH), dtype=bool)
    free[y0:y1, x0:x1] = True
    for label, mask, (bx0, by0, bx1, by1) in zip(
        truth.labels, truth.masks, truth.boxes, strict=True
    ):
        assert not (free & mask).any(), f"the region covers the {label}"
        assert bx1 < x0 or x1 <= bx0 or by1 < y0 or y1 <= by0, f"the region meets the {label} box"
    assert (region.point.x, region.point.y) == ((x0 + x1) // 2, (y0 + y1) // 2)


def test_describe_publishes_the_scene_outputs_and_no_masks(
    client: Client, scene: tuple[Path, Scene]
) -> None:
    from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

    _, truth = scene
    text = client.subscribe("/vision/what_is_there/scene_description", StampedString)
    objects = client.subscribe("/vision/what_is_there/scene_objects", StampedString)
    detections = client.subscribe("/vision/what_is_there/detections", VisionDetectionArray)
    reply = client.create_skill(
        {
            "name": "what_is_there",
            "mode": "describe",
            "once": True,
            "outputs": [
                {"name": "scene_description", "type": "text", "description": "the scene"},
                {"name": "scene_objects", "type": "list", "description": "main objects"},
            ],
        }
    )

    description = first_result(text, "the scene_description output")
    listed = first_result(objects, "the scene_objects output")
    assert set(reply["topics"]["outputs"]) == {"scene_description", "scene_objects"}
    assert description.header.frame_id == "camera"
    assert json.loads(description.data) == truth.description
    assert sorted(json.loads(listed.data)) == sorted(truth.labels)
    assert listed.header.stamp == description.header.stamp
    wait_until(lambda: detections, WAIT_S, "the describe detections array", interval_s=0.05)
    assert all(not array.detections for array in detections)
