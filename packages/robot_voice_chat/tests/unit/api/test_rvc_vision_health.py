"""readyz counts the camera / vision node (issue 23 item 5): a dead vision node makes the
brain ``degraded`` and says why, as a dead MCP server does."""

from __future__ import annotations

import httpx
import respx

from robot_stack_testing.brain.harness import nav_servers
from robot_stack_testing.brain.life import brain_life
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.services.camera.base import (
    CameraFeed,
    CameraFrame,
    FakeCameraFeed,
    VisionHealth,
)
from robot_voice_chat.services.camera.http import HttpCameraFeed
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.tools.fake import FakeToolBackend


def container_with(camera: CameraFeed | None) -> Container:
    # every MCP server connected
    return brain_life(FakeLLM([]), tools=FakeToolBackend(nav_servers()), camera=camera)


async def readyz(camera: CameraFeed | None) -> dict[str, object]:
    app = create_app(container_with(camera), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        body: dict[str, object] = (await c.get("/api/readyz")).json()
    return body


async def test_a_dead_vision_node_makes_readyz_degraded_and_says_why(unused_tcp_port: int) -> None:
    feed = HttpCameraFeed(f"http://127.0.0.1:{unused_tcp_port}", timeout_s=1.0)
    try:
        ready = await readyz(feed)
    finally:
        await feed.aclose()
    assert ready["status"] == "degraded"
    data = ready["data"]
    assert isinstance(data, dict)
    assert set(data["mcp_servers"].values()) == {"connected"}
    assert data["vision"]["state"] == "unreachable"
    assert "not reachable" in data["vision"]["detail"]


async def test_a_seeing_camera_is_ready_and_no_camera_is_not_counted() -> None:
    ok = await readyz(FakeCameraFeed(CameraFrame(b"\xff\xd8", "image/jpeg")))
    assert ok["status"] == "ready"
    assert ok["data"]["vision"] == {"state": "ok", "detail": ""}  # type: ignore[index]
    none = await readyz(None)
    assert none["status"] == "ready"
    assert none["data"]["vision"] is None  # type: ignore[index]
    down = await FakeCameraFeed().health()
    assert down == VisionHealth("unreachable", "the fake camera has no frame")


@respx.mock
async def test_the_http_feed_reads_the_vision_nodes_own_healthz() -> None:
    route = respx.get("http://127.0.0.1:9112/healthz")
    feed = HttpCameraFeed("http://127.0.0.1:9112/")
    try:
        route.mock(return_value=httpx.Response(200, json={"status": "ok"}))
        assert await feed.health() == VisionHealth("ok")
        route.mock(return_value=httpx.Response(503, json={"status": "degraded", "why": "no frame"}))
        degraded = await feed.health()
    finally:
        await feed.aclose()
    assert degraded.state == "degraded"
    assert "503" in degraded.detail
    assert "no frame" in degraded.detail
