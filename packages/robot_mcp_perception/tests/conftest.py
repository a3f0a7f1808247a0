"""Shared fixtures of the vision-node runtime tests: an in-process node on fakes, a ROS probe.

The node runs in a fresh rclpy Context spun by a MultiThreadedExecutor thread; frames come
from a :class:`ManualFrameSource` the test pushes into; models are the fakes at the ports.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import structlog

from robot_mcp_perception.frames import FrameListener, FrameSource
from robot_mcp_perception.models.base import (
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    Segmenter,
)
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.watch import FrameDiffGate
from robot_mcp_perception.runtime import Runtime
from robot_mcp_perception.settings import PerceptionSettings

RUNNER = run_skill
"""The real router: a broken ``pipelines`` import fails every node test at collection."""
GATE = FrameDiffGate


class ManualFrameSource(FrameSource):
    """Frames pushed by the test; ``push`` emits like a camera callback would."""

    def __init__(self) -> None:
        super().__init__("test_camera")
        self.started = False

    def start(self, node: Any, on_frame: FrameListener | None = None) -> None:
        self._listener = on_frame
        self.started = True

    def stop(self) -> None:
        self.started = False

    def push(self, image: Image, stamp_ns: int | None = None, frame_id: str | None = None) -> Any:
        return self._emit(image, stamp_ns, frame_id)


def scene(value: int = 40, height: int = 120, width: int = 160) -> Image:
    """A flat frame with a brighter square; different ``value`` → a different scene."""
    image = np.full((height, width, 3), value, dtype=np.uint8)
    image[30:90, 40:120] = min(value + 120, 255)
    return image


MUG = GroundedTarget(label="red mug", box=(40, 30, 120, 90), points=[(80, 60)], confidence=0.9)
MUG_RESULT = GroundingResult(
    answer="a red mug", targets=[MUG], outputs={"found": True, "count": 1, "scene": "a red mug"}
)


def make_settings(**sections: Any) -> PerceptionSettings:
    data: dict[str, Any] = {
        "grounder": {"_target_": "tests.FakeGrounder", "cost_class": "cloud"},
        "segmenter": {"_target_": "tests.NullSegmenter"},
        "frame_source": {"_target_": "tests.ManualFrameSource"},
        # Tests push frames with fixed historic stamps: no waiting for a frame captured after
        # a skill was taken up (the engine tests cover that rule).
        "node": {
            "processing_frequency": 5.0,
            "tick_hz": 50.0,
            "model_timeout_s": 2.0,
            "fresh_frame_wait_s": 0.0,
        },
        "artifacts": {"enabled": False},
        "logging": {"json_logs": True, "level": "DEBUG"},
    }
    for key, value in sections.items():
        data[key] = {**data.get(key, {}), **value}
    return PerceptionSettings.model_validate(data)


class RosProbe:
    """A second node (same context) that calls the vision services and records topics."""

    def __init__(self, node: Any, service_prefix: str) -> None:
        self.node = node
        self.prefix = service_prefix
        self._clients: dict[str, Any] = {}
        self.received: dict[str, list[Any]] = {}
        self._lock = threading.Lock()

    def call(
        self, service: str, data: dict[str, Any] | str, timeout_s: float = 10.0
    ) -> tuple[bool, dict[str, Any]]:
        from ros2_vision_interfaces.srv import VisionTask

        client = self._clients.get(service)
        if client is None:
            client = self.node.create_client(VisionTask, f"{self.prefix}/{service}")
            self._clients[service] = client
        if not client.wait_for_service(timeout_sec=timeout_s):
            raise TimeoutError(f"service {service} not available")
        request = VisionTask.Request()
        request.data = data if isinstance(data, str) else json.dumps(data)
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s):
            client.remove_pending_request(future)
            raise TimeoutError(f"no reply from {service} within {timeout_s} s")
        response = future.result()
        return bool(response.success), json.loads(response.message)

    def subscribe(self, topic: str, msg_type: Any, durable: bool = True) -> list[Any]:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        messages: list[Any] = []
        self.received[topic] = messages
        qos = QoSProfile(
            depth=50,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if durable else DurabilityPolicy.VOLATILE,
        )

        def record(msg: Any) -> None:
            with self._lock:
                messages.append(msg)

        self.node.create_subscription(msg_type, topic, record, qos)
        return messages

    def topics(self) -> set[str]:
        return {name for name, _ in self.node.get_topic_names_and_types()}


class NodeHarness:
    def __init__(
        self,
        node: Any,
        probe: RosProbe,
        source: ManualFrameSource,
        grounder: Grounder,
        segmenter: Segmenter,
    ) -> None:
        self.node = node
        self.probe = probe
        self.source = source
        self.grounder = grounder
        self.segmenter = segmenter

    def create(self, skill: dict[str, Any]) -> dict[str, Any]:
        ok, reply = self.probe.call("create_vision_task", skill)
        assert ok, reply
        return reply

    def pump(
        self,
        until: Callable[[], Any],
        timeout_s: float = 10.0,
        image: Image | None = None,
        what: str = "condition",
    ) -> Any:
        """Push the same frame (or ``image``) at ~20 Hz until ``until()`` is truthy."""
        frame_image = scene() if image is None else image
        deadline = time.monotonic() + timeout_s
        while True:
            result = until()
            if result:
                return result
            if time.monotonic() > deadline:
                raise TimeoutError(f"timed out after {timeout_s}s waiting for {what}")
            self.source.push(frame_image)
            time.sleep(0.05)


@pytest.fixture
def log_events() -> Iterator[list[dict[str, Any]]]:
    with structlog.testing.capture_logs() as captured:
        yield captured


@pytest.fixture
def start_node() -> Iterator[Callable[..., NodeHarness]]:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor

    from robot_mcp_perception.vision_node import VisionNode

    started: list[tuple[Any, Any, Any, threading.Thread, Any]] = []

    def start(
        grounder: Grounder | None = None,
        segmenter: Segmenter | None = None,
        settings: PerceptionSettings | None = None,
        runner: Any = None,
        gate_factory: Any = GATE,
        serve_artifacts: bool = False,
        overlay_renderer: Any = None,
    ) -> NodeHarness:
        context = Context()
        rclpy.init(context=context)
        source = ManualFrameSource()
        grounder = grounder or FakeGrounder(MUG_RESULT)
        segmenter = segmenter or NullSegmenter()
        runtime = Runtime(
            settings=settings or make_settings(),
            grounder=grounder,
            segmenter=segmenter,
            frame_source=source,
            runner=runner or RUNNER,
            gate_factory=gate_factory,
            overlay_renderer=overlay_renderer,
            serve_artifacts=serve_artifacts,
        )
        node = VisionNode(runtime, context=context)
        probe_node = rclpy.create_node("probe", context=context)
        executor = MultiThreadedExecutor(num_threads=4, context=context)
        executor.add_node(node)
        executor.add_node(probe_node)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        started.append((context, node, probe_node, thread, executor))
        return NodeHarness(
            node, RosProbe(probe_node, f"/{node.get_name()}"), source, grounder, segmenter
        )

    yield start
    for context, node, probe_node, thread, executor in started:
        executor.shutdown(timeout_sec=2.0)
        thread.join(timeout=5.0)
        node.shutdown()
        node.destroy_node()
        probe_node.destroy_node()
        rclpy.try_shutdown(context=context)  # a test may have shut it down (a signal's way)


@pytest.fixture
def settings_factory() -> Callable[..., PerceptionSettings]:
    return make_settings


@pytest.fixture
def scene_factory() -> Callable[..., Image]:
    return scene


@pytest.fixture
def mug_result() -> GroundingResult:
    return MUG_RESULT
