"""The operator UI's routes: static files at /, chat history, camera proxy, detections, map."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import respx
import socketio

from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.api.app import create_app, create_asgi_app
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.services.camera.base import CameraFrame, CameraOfflineError, FakeCameraFeed
from robot_voice_chat.services.camera.http import HttpCameraFeed
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.speech.none import NoSpeechInput
from robot_voice_chat.services.tools.base import ToolOutcome
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AppConfig
from robot_voice_chat.socket_events import ChatDelta, ChatError, ChatMessage, MissionFinished

JPEG = b"\xff\xd8\xff\xe0fake-jpeg"
SCENE = {
    "mode": "warm",
    "scene_description": {
        "skill": "describe",
        "value": "a shelf with a yellow package",
        "age_s": 3.5,
    },
    "skills": [
        {
            "skill": "find_object",
            "age_s": 0.4,
            "stale": False,
            "detections": [{"label": "yellow package", "score": 0.91, "box": [1, 2, 3, 4]}],
        }
    ],
}
POSE = {"x": 1.5, "y": -2.0, "theta": 0.3, "moving": True, "destination": "mailroom"}


def container_for(
    tmp_path: Path,
    tools: FakeToolBackend | None = None,
    camera: FakeCameraFeed | HttpCameraFeed | None = None,
    static_dir: Path | None = None,
    sio: Any = None,
) -> Container:
    config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": str(tmp_path / "traces"), "memory_server": ""},
            "ui": {"static_dir": str(static_dir or tmp_path / "no-build"), "chat_history_size": 3},
        }
    )
    adapters = Adapters(
        llm=FakeLLM([]),
        planner=FakeLLM([]),
        tools=tools or FakeToolBackend(),
        speech_output=FakeSpeechOutput(),
        speech_input=NoSpeechInput(),
        camera=camera,
    )
    return assemble(config, adapters, FakeEventEmitter(), sio)


@pytest.fixture
def built_ui(tmp_path: Path) -> Path:
    static = tmp_path / "static"
    (static / "assets").mkdir(parents=True)
    (static / "index.html").write_text("<!doctype html><div id=root></div>")
    (static / "assets" / "app.js").write_text("console.log('ui')")
    return static


async def client_for(app: Any) -> AsyncIterator[httpx.AsyncClient]:
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        yield c


@pytest.fixture
async def tools_client(tmp_path: Path) -> AsyncIterator[tuple[httpx.AsyncClient, FakeToolBackend]]:
    tools = FakeToolBackend()
    app = create_app(container_for(tmp_path, tools), manage_lifecycle=False)
    async for c in client_for(app):
        yield c, tools


async def test_the_built_ui_is_served_at_root_without_shadowing_the_api(
    tmp_path: Path, built_ui: Path
) -> None:
    app = create_app(container_for(tmp_path, static_dir=built_ui), manage_lifecycle=False)
    async for c in client_for(app):
        index = await c.get("/")
        asset = await c.get("/assets/app.js")
        live = await c.get("/api/livez")
        unknown_api = await c.get("/api/no-such-route")
    assert index.status_code == 200
    assert "id=root" in index.text
    assert asset.status_code == 200
    assert "javascript" in asset.headers["content-type"]
    assert live.json() == {"status": "ok"}
    assert unknown_api.status_code == 404
    assert "id=root" not in unknown_api.text


async def test_socketio_is_answered_before_the_static_mount(tmp_path: Path, built_ui: Path) -> None:
    sio = socketio.AsyncServer(async_mode="asgi")
    app = create_asgi_app(container_for(tmp_path, static_dir=built_ui, sio=sio))
    async for c in client_for(app):
        handshake = await c.get("/socket.io/", params={"EIO": "4", "transport": "polling"})
    assert handshake.status_code == 200
    assert '"sid"' in handshake.text


async def test_an_unbuilt_ui_says_how_to_build_it(tmp_path: Path) -> None:
    app = create_app(container_for(tmp_path), manage_lifecycle=False)
    async for c in client_for(app):
        page = await c.get("/")
    assert page.status_code == 503
    assert "make setup" in page.text


async def test_chat_history_keeps_the_last_complete_lines_but_no_deltas(tmp_path: Path) -> None:
    container = container_for(tmp_path)
    for event in (
        ChatMessage(turn_id="t0", role="user", text="dropped by the bound"),
        ChatMessage(turn_id="t1", role="user", text="hello"),
        ChatDelta(turn_id="t1", text="Hi"),
        ChatMessage(turn_id="t1", role="assistant", text="Hi there"),
        ChatError(turn_id="t2", message="Sorry"),
    ):
        await container.emitter.emit(event)
    await container.emitter.emit(MissionFinished(mission_id="m-1", outcome="failed", summary="x"))
    app = create_app(container, manage_lifecycle=False)
    async for c in client_for(app):
        lines = (await c.get("/api/chat/history")).json()["lines"]
        last = (await c.get("/api/chat/history", params={"limit": 1})).json()["lines"]
        bad = await c.get("/api/chat/history", params={"limit": 0})
    assert [line["event"] for line in lines] == ["chat_message", "chat_error", "mission_finished"]
    assert lines[0]["text"] == "Hi there"
    assert all(isinstance(line["ts"], float) for line in lines)
    assert last[0]["mission_id"] == "m-1"
    assert bad.status_code == 422


async def test_a_finished_mission_in_the_history_keeps_its_human_title(tmp_path: Path) -> None:
    """Issue 39: after a page reload the card was titled "Mission m-af2fa4"."""
    container = container_for(tmp_path)
    mission = Mission.new("go to the kitchen")
    container.executor.store.add(mission)
    await container.emitter.emit(
        MissionFinished(mission_id=mission.id, outcome="succeeded", summary="I'm in the kitchen.")
    )
    await container.emitter.emit(
        MissionFinished(mission_id="m-gone", outcome="failed", summary="x")
    )
    app = create_app(container, manage_lifecycle=False)
    async for c in client_for(app):
        lines = (await c.get("/api/chat/history")).json()["lines"]
    assert [line.get("instruction") for line in lines] == ["go to the kitchen", ""]


async def test_camera_frame_is_proxied_without_caching(tmp_path: Path) -> None:
    camera = FakeCameraFeed(CameraFrame(JPEG, "image/jpeg"))
    app = create_app(container_for(tmp_path, camera=camera), manage_lifecycle=False)
    async for c in client_for(app):
        frame = await c.get("/api/camera/frame")
    assert frame.status_code == 200
    assert frame.content == JPEG
    assert frame.headers["content-type"] == "image/jpeg"
    assert frame.headers["cache-control"] == "no-store"


@pytest.mark.parametrize("camera", [None, FakeCameraFeed()])
async def test_camera_offline_is_a_503_json(tmp_path: Path, camera: FakeCameraFeed | None) -> None:
    app = create_app(container_for(tmp_path, camera=camera), manage_lifecycle=False)
    async for c in client_for(app):
        frame = await c.get("/api/camera/frame")
    assert frame.status_code == 503
    assert frame.json()["error"] == "camera_offline"


async def test_the_http_camera_feed_reports_a_down_node_as_offline(
    tmp_path: Path, unused_tcp_port: int
) -> None:
    feed = HttpCameraFeed(f"http://127.0.0.1:{unused_tcp_port}", timeout_s=1.0)
    app = create_app(container_for(tmp_path, camera=feed), manage_lifecycle=False)
    async for c in client_for(app):
        frame = await c.get("/api/camera/frame")
    await feed.aclose()
    assert frame.status_code == 503
    assert "not reachable" in frame.json()["detail"]


@respx.mock
async def test_the_http_camera_feed_passes_frames_and_maps_node_errors() -> None:
    route = respx.get("http://127.0.0.1:9112/frames/latest.jpg")
    feed = HttpCameraFeed("http://127.0.0.1:9112/")
    route.mock(
        return_value=httpx.Response(200, content=JPEG, headers={"content-type": "image/jpeg"})
    )
    frame = await feed.latest_frame()
    route.mock(return_value=httpx.Response(503, json={"error": "no_frame"}))
    with pytest.raises(Exception, match="has no frame"):
        await feed.latest_frame()
    await feed.aclose()
    assert frame == CameraFrame(JPEG, "image/jpeg")


@respx.mock
async def test_html_from_the_camera_upstream_is_refused(tmp_path: Path) -> None:
    script = b"<html><script>fetch('/api/chat/stop', {method: 'POST'})</script></html>"
    respx.get("http://127.0.0.1:9112/frames/latest.jpg").mock(
        return_value=httpx.Response(200, content=script, headers={"content-type": "text/html"})
    )
    feed = HttpCameraFeed("http://127.0.0.1:9112")
    app = create_app(container_for(tmp_path, camera=feed), manage_lifecycle=False)
    async for c in client_for(app):
        frame = await c.get("/api/camera/frame")
    await feed.aclose()
    assert frame.status_code == 503
    assert frame.headers["content-type"] == "application/json"
    assert "'text/html', not an image" in frame.json()["detail"]
    assert b"<script>" not in frame.content


@respx.mock
async def test_a_camera_frame_larger_than_the_cap_is_refused() -> None:
    route = respx.get("http://127.0.0.1:9112/frames/latest.jpg")
    feed = HttpCameraFeed("http://127.0.0.1:9112", max_bytes=1000)
    big = b"\xff\xd8" + b"\0" * 2000
    route.mock(
        return_value=httpx.Response(200, content=big, headers={"content-type": "image/jpeg"})
    )
    with pytest.raises(CameraOfflineError, match="larger than 1000 bytes"):
        await feed.latest_frame()

    async def unsized() -> AsyncIterator[bytes]:  # no Content-Length: counted while read
        for _ in range(4):
            yield b"\0" * 400

    route.mock(
        return_value=httpx.Response(200, content=unsized(), headers={"content-type": "image/png"})
    )
    with pytest.raises(CameraOfflineError, match="larger than 1000 bytes"):
        await feed.latest_frame()
    await feed.aclose()


async def test_a_camera_adapter_that_returns_a_non_image_is_not_served(tmp_path: Path) -> None:
    camera = FakeCameraFeed(CameraFrame(b"<svg onload=alert(1)>", "image/svg+xml"))
    app = create_app(container_for(tmp_path, camera=camera), manage_lifecycle=False)
    async for c in client_for(app):
        frame = await c.get("/api/camera/frame")
    assert frame.status_code == 503


async def test_detections_flatten_the_perception_buffer(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, tools = tools_client
    tools.add("perception.what_do_you_see", lambda a: SCENE)
    body = (await c.get("/api/camera/detections")).json()
    assert body["scene"] == "a shelf with a yellow package"
    assert body["scene_age_s"] == 3.5
    assert body["detections"] == [
        {
            "label": "yellow package",
            "score": 0.91,
            "skill": "find_object",
            "age_s": 0.4,
            "stale": False,
        }
    ]


async def test_detections_without_perception_are_a_503_json(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, _ = tools_client
    response = await c.get("/api/camera/detections")
    assert response.status_code == 503
    assert response.json()["error"] == "perception_unavailable"


async def test_pose_and_locations_come_from_navigation(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, tools = tools_client
    tools.add("navigation.get_pose", lambda a: POSE)
    tools.add("navigation.list_locations", lambda a: {"map": "office", "locations": []})
    assert (await c.get("/api/map/pose")).json() == POSE
    assert (await c.get("/api/map/locations")).json()["map"] == "office"
    assert [name for name, _ in tools.calls] == ["navigation.get_pose", "navigation.list_locations"]


async def test_places_carry_the_names_people_use_never_their_map_ids(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, tools = tools_client
    listed = [
        {
            "name": "desk_alice",
            "description": "Alice's desk in the open-plan office.",
            "x": 6,
            "y": 8,
        },
        {
            "name": "corridor_b",
            "description": "East corridor; leads to the mailroom.",
            "x": 1,
            "y": 2,
        },
        {"name": "meeting_room", "description": 'Meeting room "Harbour".', "x": 3, "y": 4},
        {"name": "lab_3", "description": "", "x": 0, "y": 0},
    ]
    tools.add("navigation.list_locations", lambda a: {"map": "office", "locations": listed})
    body = (await c.get("/api/map/locations")).json()
    labels = [loc["label"] for loc in body["locations"]]
    assert labels == ["Alice's desk", "East corridor", "Meeting room Harbour", "Lab 3"]
    assert body["locations"][0]["name"] == "desk_alice"  # ids stay for requests


async def test_the_floor_plan_and_the_plan_come_from_navigations_map_tools(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, tools = tools_client
    floor = {"available": True, "walls_png": "iVBOR", "blocked": [], "bounds": {"x0": 0}}
    tools.add("navigation.get_map", lambda a: floor)
    tools.add("navigation.get_plan", lambda a: {"frame": "map", "points": [[0, 0], [1, 2]]})
    assert (await c.get("/api/map/floor")).json() == floor
    assert (await c.get("/api/map/plan")).json()["points"] == [[0, 0], [1, 2]]
    tools.add("navigation.get_map", lambda a: ToolOutcome(text="down", is_error=True))
    assert (await c.get("/api/map/floor")).status_code == 503


@pytest.mark.parametrize(
    "answer",
    [ToolOutcome(text="boom", is_error=True), "not json", "[1, 2]"],
    ids=["tool-error", "not-json", "not-an-object"],
)
async def test_a_bad_navigation_answer_is_a_503_json(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend], answer: Any
) -> None:
    c, tools = tools_client
    tools.add("navigation.get_pose", lambda a: answer)
    response = await c.get("/api/map/pose")
    assert response.status_code == 503
    assert response.json()["error"] == "navigation_unavailable"


async def test_what_the_robot_holds_comes_from_the_arm_and_no_arm_is_a_503(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, tools = tools_client
    missing = await c.get("/api/robot/held")  # no manipulation server connected
    assert missing.status_code == 503
    assert missing.json()["error"] == "manipulation_unavailable"
    held = {"known": True, "holding": True, "label": "yellow package", "since": 1.0}
    tools.add("manipulation.get_held", lambda a: held)
    assert (await c.get("/api/robot/held")).json() == held


async def test_ui_config_tells_the_browser_what_it_may_do(
    tools_client: tuple[httpx.AsyncClient, FakeToolBackend],
) -> None:
    c, _ = tools_client
    config = (await c.get("/api/ui/config")).json()
    assert config["speech_input"] is False
    assert "speech_input: none" in config["speech_input_reason"]
    assert config["speech_output_browser"] is False
    assert config["deployment"] == "dev"
    assert config["auth"] is False
