"""Recording over ROS from the REAL vision node (a separate process, offline: folder frames +
annotation grounder) into the index and MCAP, by a real ``robot-mcp-episodic`` server process
(streamable-http); the MCAP is read back with rosbags and compared with what this test
received itself. Then kill -9 and a restart: what was flushed survives."""

from __future__ import annotations

import shutil
import signal
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from rosbags.highlevel import AnyReader

from robot_mcp_perception.composition import default_config_dir
from robot_mcp_perception.sample_scenes import generate_scenes
from robot_ros_bridge import RosBridge
from robot_ros_bridge.vision_tasks import RosVisionTasks
from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    async_wait_until,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.kit.tool_calls import tool_answer

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
KITCHEN = (9.0, -3.0)


def vision_env(tmp_path: Path, node: str) -> dict[str, str]:
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
        "PERCEPTION_CONFIG_DIR": str(config),
        "PERCEPTION_CONFIG_OVERRIDES": (
            f"grounder=it_annotation segmenter=it_none frame_source=folder "
            f"frame_source.directory={frames} frame_source.fps=4 "
            f"artifacts.port={free_tcp_port()} node.node_name={node} "
            "node.default_skills.0.rate_hz=2"
        ),
    }


@pytest.fixture
def graph() -> Iterator[RosBridge]:
    with RosBridge(f"episodic_test_{uuid.uuid4().hex[:6]}") as bridge:
        yield bridge


class PosePublisher:
    def __init__(self, bridge: RosBridge, topic: str) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped

        self._type = PoseWithCovarianceStamped
        self._publisher = bridge.create_publisher(PoseWithCovarianceStamped, topic)
        self.sent: list[float] = []

    def publish(self, x: float, y: float) -> None:
        msg = self._type()
        now = time.time()
        msg.header.stamp.sec = int(now)
        msg.header.stamp.nanosec = int((now % 1) * 1e9)
        msg.header.frame_id = "map"
        msg.pose.pose.position.x = x
        msg.pose.pose.position.y = y
        msg.pose.pose.orientation.w = 1.0
        self._publisher.publish(msg)
        self.sent.append(x)


def start_server(
    launcher: ProcessLauncher, data_dir: Path, pose_topic: str
) -> tuple[LaunchedProcess, str]:
    port = free_tcp_port()
    process = launcher.start(
        "episodic",
        [sys.executable, "-m", "robot_mcp_episodic"],
        env={
            "MCP_TRANSPORT": "streamable-http",
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_PORT": str(port),
            "EPISODIC_DIR": str(data_dir),
            "EPISODIC_POSE_TOPIC": pose_topic,
            "EPISODIC_FLUSH_S": "0.2",
        },
    )
    wait_for_tcp_port(port, 45.0)
    return process, f"http://127.0.0.1:{port}/mcp"


def bag_messages(data_dir: Path) -> list[tuple[str, Any]]:
    found = []
    for bag in sorted((data_dir / "bags").iterdir()):
        with AnyReader([bag]) as reader:
            for connection, _, raw in reader.messages():
                found.append((connection.topic, reader.deserialize(raw, connection.msgtype)))
    return found


def frame_key(msg: Any) -> tuple[Any, ...]:
    return (
        msg.header.stamp.sec, msg.header.stamp.nanosec,
        tuple((d.label, round(float(d.score), 4), d.box.x_offset, d.box.width)
              for d in msg.detections),
    )  # fmt: skip


async def test_the_real_vision_node_is_recorded_into_index_and_mcap_and_survives_kill_9(
    launcher: ProcessLauncher, graph: RosBridge, tmp_path: Path
) -> None:
    from ros2_vision_interfaces.msg import VisionDetectionArray

    node = f"vision_{uuid.uuid4().hex[:6]}"
    pose_topic = f"/pose_{uuid.uuid4().hex[:6]}"
    data_dir = tmp_path / "episodic"
    vision = launcher.start(
        "vision", [sys.executable, "-m", "robot_mcp_perception.vision_node"],
        env=vision_env(tmp_path, node),
    )  # fmt: skip
    server, url = start_server(launcher, data_dir, pose_topic)
    poses = PosePublisher(graph, pose_topic)
    received: list[Any] = []
    graph.create_subscription(
        VisionDetectionArray, "/vision/everything/detections_meta", received.append
    )
    tasks = RosVisionTasks(graph, node, timeout_s=15.0, wait_for_service_s=30.0)
    made = await tasks.create({"name": "everything", "mode": "segment_all", "rate_hz": 2.0})
    assert made["topics"]["detections_meta"] == "/vision/everything/detections_meta", vision.log()[
        -2000:
    ]

    async with Client(mcp_transport(url, TOKEN)) as client:

        async def the_skills_sighting(label: str) -> dict[str, Any] | None:
            # the scene describer's objects are sightings too: this test's skill's own
            answer = await tool_answer(client, "last_seen", {"query": label, "n": 10})
            return next((r for r in answer.get("results", []) if r["skill"] == "everything"), None)

        async def a_label_is_remembered() -> bool:
            poses.publish(*KITCHEN)
            labels = {d.label for m in list(received) for d in m.detections}
            for label in labels:
                sighting = await the_skills_sighting(label)
                if sighting is not None and sighting["place"] == "kitchen":
                    return True
            return False

        # Frames that arrive before the first pose are remembered without a place.
        await async_wait_until(a_label_is_remembered, 60.0, "a sighting in the kitchen")
        label = next(d.label for m in reversed(received) for d in m.detections)
        top = await the_skills_sighting(label)
        assert top is not None
        assert top["place"] == "kitchen"
        assert top["robot_pose"]["x"] == pytest.approx(KITCHEN[0])

        async def scene_noted() -> bool:
            happened = await tool_answer(client, "what_happened", {"kinds": ["scene"]})
            return bool(happened.get("items"))

        await async_wait_until(scene_noted, 60.0, "a scene description note")
        status = await tool_answer(client, "memory_status", {})
        assert status["index"]["poses"]["rows"] >= 1
        assert "detections:everything" in status["last_write"]

    assert launcher.stop(server) == 0, server.log()[-2000:]
    recorded = bag_messages(data_dir)
    metas = [m for topic, m in recorded if topic == "/vision/everything/detections_meta"]
    assert metas, server.log()[-2000:]
    mine = {frame_key(m) for m in received}
    assert all(frame_key(m) in mine for m in metas)  # the same messages, field for field
    assert all(len(d.mask.data) == 0 for m in metas for d in m.detections)  # never masks
    topics = {topic for topic, _ in recorded}
    assert pose_topic in topics
    assert "/vision/scene/scene_description" in topics
    assert "/vision/everything/detections" not in topics

    # kill -9 while recording; the restart repairs the bag and keeps what was flushed.
    server, url = start_server(launcher, data_dir, pose_topic)
    before_kill = len(received)
    await async_wait_until(lambda: _more(received, before_kill + 4), 30.0, "more frames")
    async with Client(mcp_transport(url, TOKEN)) as client:

        async def pose_flushed() -> bool:
            poses.publish(*KITCHEN)
            status = await tool_answer(client, "memory_status", {})
            # flushed to the file: what the kill below cannot take back
            return int(status["recordings"]["messages_on_disk"]) > len(recorded)

        await async_wait_until(pose_flushed, 30.0, "recording in the second run")
    server.popen.send_signal(signal.SIGKILL)
    server.popen.wait(timeout=10)
    server, url = start_server(launcher, data_dir, pose_topic)
    assert "episodic_bag_repaired" in server.log()
    async with Client(mcp_transport(url, TOKEN)) as client:
        answer = await tool_answer(client, "last_seen", {"query": label})
        assert answer["found"]
    launcher.stop(server)
    assert len(bag_messages(data_dir)) > len(recorded)


async def _more(received: list[Any], count: int) -> bool:
    return len(received) >= count
