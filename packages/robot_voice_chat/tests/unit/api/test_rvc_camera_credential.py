"""The brain's camera proxy sends the vision node's credential (issue 35: the node's pictures
now need ``ARTIFACTS_AUTH_TOKEN``; the brain holds it as ``VISION_ARTIFACTS_TOKEN``)."""

from __future__ import annotations

import httpx
import pytest
import respx
import structlog
from pydantic import SecretStr

from robot_voice_chat.composition import build_adapters, compose_config
from robot_voice_chat.services.camera.base import CameraFrame, CameraOfflineError
from robot_voice_chat.services.camera.http import HttpCameraFeed
from robot_voice_chat.services.emitter.base import FakeEventEmitter

TOKEN = "the-vision-nodes-artifacts-credential-0123"
JPEG = b"\xff\xd8\xff\xe0fake-jpeg"
FRAME_URL = "http://127.0.0.1:9112/frames/latest.jpg"


def _node_that_wants(token: str | None) -> respx.Route:
    """A stand-in vision node: the frame for its credential, 401 otherwise."""

    def answer(request: httpx.Request) -> httpx.Response:
        if token is not None and request.headers.get("authorization") == f"Bearer {token}":
            return httpx.Response(200, content=JPEG, headers={"content-type": "image/jpeg"})
        return httpx.Response(401, headers={"www-authenticate": 'Bearer realm="vision"'})

    return respx.get(FRAME_URL).mock(side_effect=answer)


@respx.mock
async def test_the_brain_composed_from_its_environment_sends_the_vision_credential(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("VISION_ARTIFACTS_TOKEN", TOKEN)
    monkeypatch.setenv("RVC_CAMERA_URL", "http://127.0.0.1:9112")
    config = compose_config("dev")
    route = _node_that_wants(TOKEN)
    with structlog.testing.capture_logs() as logs:
        camera = build_adapters(config, FakeEventEmitter()).camera
    assert camera is not None

    frame = await camera.latest_frame()
    await camera.aclose()

    assert frame == CameraFrame(JPEG, "image/jpeg")
    assert route.calls.last.request.headers["authorization"] == f"Bearer {TOKEN}"
    assert TOKEN not in repr(config.ui) + repr(logs)


@respx.mock
async def test_a_refused_credential_is_an_offline_camera_that_says_what_to_set() -> None:
    _node_that_wants(TOKEN)
    without = HttpCameraFeed("http://127.0.0.1:9112")
    wrong = HttpCameraFeed("http://127.0.0.1:9112", token=SecretStr("y" * 40))

    for feed in (without, wrong):
        with pytest.raises(CameraOfflineError, match="VISION_ARTIFACTS_TOKEN") as refused:
            await feed.latest_frame()
        await feed.aclose()
        assert TOKEN not in str(refused.value)


def test_an_empty_vision_credential_is_none(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VISION_ARTIFACTS_TOKEN", "  ")
    assert compose_config("dev").ui.camera_token is None
