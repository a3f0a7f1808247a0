"""Watcher end to end with the REAL vision node (ARCHITECTURE.md §4.4, spec 001 §5).

The SDK's MCP client drives mcp-skill-control and mcp-perception-buffer server processes
(streamable-http on loopback); a real ``vision_node`` process (offline defaults: folder frames
+ annotation grounder) runs a ``watch_for`` skill on a frame folder the TEST changes over time
(the folder source rescans its directory after every pass); the buffer posts signed
``watch_event``s to a real HMAC-verifying receiver.

    frames without a red mug  -> no event
    frames with one           -> exactly one watch_event (server perception, task watch-…)
    staying true              -> nothing more
    false, then true again    -> a second event with a higher seq
    perception.cancel_task    -> disarmed, skill stopped, one task_failed CANCELLED; then nothing
"""

import json
import shutil
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robot_mcp_perception.sample_scenes import generate_scenes
from robot_ros_bridge import RosBridge
from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    async_wait_until,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
SECRET = "e2e-watch-secret"
CONDITION = "a red mug is visible"


class FrameFolder:
    """The folder the vision node plays: shows exactly one scene at a time. A new scene is
    written under a later-sorting name (atomic rename) before the old file is removed, so a
    pass of the folder source never goes back to the previous scene."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        directory.mkdir()
        self._count = 0
        self._current: Path | None = None

    def show(self, scene: Path) -> None:
        self._count += 1
        target = self.directory / f"frame_{self._count:03d}.png"
        partial = self.directory / f".frame_{self._count:03d}.tmp"
        shutil.copyfile(scene, partial)
        partial.replace(target)
        if self._current is not None:
            self._current.unlink()
        self._current = target


def _scenes_with_and_without_a_red_mug(scenes_dir: Path) -> tuple[Path, Path]:
    with_mug: Path | None = None
    without: Path | None = None
    for png in generate_scenes(scenes_dir, count=12, seed=0):
        labels = {
            a["label"] for a in json.loads(png.with_suffix(".json").read_text())["annotations"]
        }
        if "red mug" in labels and with_mug is None:
            with_mug = png
        elif "red mug" not in labels and without is None:
            without = png
    assert with_mug is not None, "no sample scene with a red mug"
    assert without is not None, "no sample scene without a red mug"
    return with_mug, without


async def call(client: Client, tool: str, args: dict[str, Any] | None = None) -> Any:
    result = await client.call_tool(tool, args or {})
    payload = json.loads(result.content[0].text)  # type: ignore[union-attr]
    return {"_error": payload} if result.is_error else payload


@pytest.fixture
def graph() -> Iterator[RosBridge]:
    with RosBridge(f"e2e_observer_{uuid.uuid4().hex[:6]}") as bridge:
        yield bridge


def _start_stack(
    launcher: ProcessLauncher, frames: Path, scenes: Path, node: str, events_url: str, state: Path
) -> tuple[LaunchedProcess, str, str]:
    vision = launcher.start(
        "vision",
        [sys.executable, "-m", "robot_mcp_perception.vision_node"],
        env={
            "PERCEPTION_CONFIG_OVERRIDES": (
                f"frame_source=folder artifacts.port={free_tcp_port()} node.node_name={node}"
            ),
            "PERCEPTION_FRAMES_DIR": str(frames),
            "PERCEPTION_ANNOTATIONS_DIR": str(scenes),
        },
    )
    ports = free_tcp_port(), free_tcp_port()
    common = {"MCP_TRANSPORT": "streamable-http", "MCP_AUTH_TOKEN": TOKEN, "VISION_NODE_NAME": node}
    launcher.start(
        "skill-control",
        [sys.executable, "-m", "mcp_skill_control"],
        env={**common, "MCP_PORT": str(ports[0])},
    )
    launcher.start(
        "perception-buffer",
        [sys.executable, "-m", "mcp_perception_buffer"],
        env={
            **common,
            "MCP_PORT": str(ports[1]),
            "RVC_EVENTS_URL": events_url,
            "RVC_EVENT_SECRET": SECRET,
            "PERCEPTION_OUTBOX_PATH": str(state / "outbox.sqlite3"),
            "PERCEPTION_GRAPH_POLL_S": "0.2",
            "PERCEPTION_WATCH_POLL_S": "0.2",
        },
    )
    for port in ports:
        wait_for_tcp_port(port, 30.0)
    return vision, f"http://127.0.0.1:{ports[0]}/mcp", f"http://127.0.0.1:{ports[1]}/mcp"


async def test_a_watch_for_skill_on_the_real_vision_node_posts_one_signed_event_per_rising_edge(
    launcher: ProcessLauncher, graph: RosBridge, tcp_port: int, tmp_path: Path
) -> None:
    with_mug, without = _scenes_with_and_without_a_red_mug(tmp_path / "scenes")
    frames = FrameFolder(tmp_path / "frames")
    frames.show(without)
    node = f"vision_{uuid.uuid4().hex[:6]}"
    receiver = RecordingReceiver({"perception": SECRET})
    async with ReceiverServer(receiver, tcp_port) as server:
        vision, skills_url, perception_url = _start_stack(
            launcher, frames.directory, tmp_path / "scenes", node, server.url, tmp_path
        )
        try:
            await async_wait_until(
                lambda: f"/{node}/create_vision_task" in graph.service_names_and_types(),
                45.0,
                "the vision node's services",
            )
        except TimeoutError:
            raise AssertionError(f"vision node did not come up:\n{vision.log()[-3000:]}") from None

        async with (
            Client(mcp_transport(skills_url, TOKEN)) as skills,
            Client(mcp_transport(perception_url, TOKEN)) as perception,
        ):
            # skill_control's own ROS node discovers the vision node on its own schedule (seconds
            # on a loaded machine): wait until it reaches the node before creating a skill.
            async def skill_control_sees_the_node() -> bool:
                return "_error" not in await call(skills, "list_running_skills", {})

            await async_wait_until(
                skill_control_sees_the_node, 45.0, "skill_control reaches the node"
            )

            async def triggered_is(value: bool) -> bool:
                latest = await call(perception, "get_latest", {"skill": "watch_for"})
                output = (
                    latest.get("outputs", {}).get("triggered") if "_error" not in latest else None
                )
                return output is not None and output["value"] is value

            made = await call(
                skills,
                "instantiate_skill",
                {"template": "watch_for", "params": {"condition": CONDITION}},
            )
            assert "_error" not in made, f"{made}\n{vision.log()[-3000:]}"
            task_id = made["task_id"]
            assert (task_id, made["server"]) == ("watch-watch_for", "perception")
            await async_wait_until(
                lambda: _task_state(perception, task_id, "running"), 30.0, "the watcher armed"
            )

            # No red mug in view: the boolean is false, nothing is posted.
            await async_wait_until(lambda: triggered_is(False), 30.0, "triggered = false")
            assert receiver.accepted() == []

            # The mug appears: exactly one signed watch_event.
            frames.show(with_mug)
            await async_wait_until(lambda: len(receiver.accepted()) >= 1, 30.0, "the first event")
            assert await triggered_is(True)

            # It stays in view: nothing more.
            with pytest.raises(TimeoutError):
                await async_wait_until(
                    lambda: len(receiver.accepted()) > 1, 4.0, "no second event while true"
                )
            assert await triggered_is(True)

            # Gone, then back: a second event with a higher seq.
            frames.show(without)
            await async_wait_until(lambda: triggered_is(False), 30.0, "triggered = false again")
            assert len(receiver.accepted()) == 1
            frames.show(with_mug)
            await async_wait_until(lambda: len(receiver.accepted()) >= 2, 30.0, "the second event")

            events = [d.event for d in receiver.accepted()]
            assert [(e.task_id, e.server, e.type, e.tool) for e in events] == [
                (task_id, "perception", "watch_event", "instantiate_skill")
            ] * 2
            assert events[1].seq > events[0].seq
            assert all(e.payload["value"] is True for e in events)
            assert all(e.payload["skill"] == "watch_for" for e in events)
            assert receiver.rejections == []  # every post carried a valid HMAC

            # cancel_task disarms and stops the skill: one task_failed CANCELLED, then nothing.
            fired = await call(perception, "get_task", {"task_id": task_id})
            assert fired["fired"] == 2
            assert len(fired["fired_at"]) == 2
            cancelled = await call(perception, "cancel_task", {"task_id": task_id})
            assert cancelled["state"] == "cancelled", cancelled
            assert cancelled["skill_stopped"] is True, cancelled
            await async_wait_until(lambda: len(receiver.accepted()) >= 3, 30.0, "the end event")
            end = receiver.accepted()[2].event
            assert (end.task_id, end.type) == (task_id, "task_failed")
            assert (end.payload["error_code"], end.payload["state"]) == ("CANCELLED", "cancelled")
            running = await call(skills, "list_running_skills")
            assert "watch_for" not in {s["skill_id"] for s in running["skills"]}
            frames.show(without)
            frames.show(with_mug)
            with pytest.raises(TimeoutError):
                await async_wait_until(
                    lambda: len(receiver.accepted()) > 3, 2.0, "no event once cancelled"
                )


async def _task_state(perception: Client, task_id: str, state: str) -> bool:
    info = await call(perception, "get_task", {"task_id": task_id})
    return bool(info.get("state") == state)
