"""``/frames/latest.jpg``: the newest camera frame with the kept skills' overlays (operator UI)."""

from __future__ import annotations

import io
from typing import Any

import httpx
import numpy as np
from PIL import Image as PILImage
from pydantic import SecretStr

from robot_mcp_perception.artifacts import ArtifactStore, build_app
from robot_mcp_perception.artifacts_auth import ArtifactsAuth
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.pipelines.common import Detection, SkillResult


def _frame(stamp_ns: int, grey: int = 90) -> Frame:
    return Frame(np.full((48, 64, 3), grey, np.uint8), stamp_ns, "cam", 1)


def _result() -> SkillResult:
    return SkillResult(
        detections=[Detection("mug", 0.9, "object", (5, 10, 25, 20), None, (15, 15))]
    )


def _paint_red_box(image: Any, result: SkillResult) -> Any:
    out = image.copy()
    x0, y0, x1, y1 = result.detections[0].box
    out[y0:y1, x0:x1] = (255, 0, 0)
    return out


TOKEN = "artifacts-credential-of-the-live-view-tests"
AUTH = ArtifactsAuth(SecretStr(TOKEN))


async def _get(app: Any, path: str) -> httpx.Response:
    async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://t") as c:
        return await c.get(path, headers={"Authorization": f"Bearer {TOKEN}"})


async def test_the_live_view_draws_kept_overlays_on_the_newest_frame() -> None:
    store = ArtifactStore("http://127.0.0.1:9112", renderer=_paint_red_box)
    store.add("find", "/vision/find/detections", _frame(1), _result())
    newest = _frame(2, grey=200)

    response = await _get(build_app(store, dict, lambda: newest, auth=AUTH), "/frames/latest.jpg")

    assert response.status_code == 200
    assert response.headers["content-type"] == "image/jpeg"
    assert response.headers["cache-control"] == "no-store"
    pixels = np.asarray(PILImage.open(io.BytesIO(response.content)))
    assert pixels.shape == (48, 64, 3)
    assert pixels[15, 15, 0] > 200  # the overlay (JPEG-lossy)
    assert pixels[15, 15, 1] < 60
    assert abs(int(pixels[40, 60, 0]) - 200) < 12  # the newest frame, not the result's


async def test_a_retired_skill_is_not_drawn_on_the_live_view() -> None:
    store = ArtifactStore("http://127.0.0.1:9112", renderer=_paint_red_box)
    store.add("find", "/vision/find/detections", _frame(1), _result())
    store.retire("find")

    response = await _get(
        build_app(store, dict, lambda: _frame(2), auth=AUTH), "/frames/latest.jpg"
    )

    pixels = np.asarray(PILImage.open(io.BytesIO(response.content)))
    assert abs(int(pixels[15, 15, 0]) - 90) < 12


async def test_no_frame_yet_is_a_503_json() -> None:
    store = ArtifactStore("http://127.0.0.1:9112")
    for app in (build_app(store, dict, lambda: None, auth=AUTH), build_app(store, dict, auth=AUTH)):
        response = await _get(app, "/frames/latest.jpg")
        assert response.status_code == 503
        assert response.json()["error"] == "no_frame"


async def test_the_live_view_draws_no_semantic_output_text() -> None:
    """Scene descriptions are words the UI shows beside the camera, not text on the image."""
    drawn: list[SkillResult] = []

    def record(image: Any, result: SkillResult) -> Any:
        drawn.append(result)
        return image

    store = ArtifactStore("http://127.0.0.1:9112", renderer=record)
    described = SkillResult(outputs={"scene_description": "A kitchen counter."})
    store.add("scene", "/vision/scene/detections", _frame(1), described)

    response = await _get(
        build_app(store, dict, lambda: _frame(2), auth=AUTH), "/frames/latest.jpg"
    )

    assert response.status_code == 200
    assert [r.outputs for r in drawn] == [{}]
    assert described.outputs == {"scene_description": "A kitchen counter."}  # kept for the API
