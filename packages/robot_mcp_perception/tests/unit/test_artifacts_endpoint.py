"""Artifacts endpoint: /healthz, masks by mask_ref, overlays, bounded memory."""

from __future__ import annotations

import io
from typing import Any

import httpx
import numpy as np
from PIL import Image as PILImage
from pydantic import SecretStr

from robot_mcp_perception.artifacts import ArtifactServer, ArtifactStore, build_app
from robot_mcp_perception.artifacts_auth import ArtifactsAuth
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.pipelines.common import Detection, SkillResult
from robot_stack_testing import wait_for_tcp_port


def _result(height: int = 48, width: int = 64) -> SkillResult:
    mask = np.zeros((height, width), dtype=bool)
    mask[10:20, 5:25] = True
    return SkillResult(
        detections=[
            Detection("mug", 0.9, "object", (5, 10, 25, 20), mask, (15, 15)),
            Detection("table", 0.5, "region", (0, 0, 10, 10), None, (5, 5)),
        ]
    )


def _frame(stamp_ns: int) -> Frame:
    return Frame(np.full((48, 64, 3), 90, np.uint8), stamp_ns, "cam", 1)


TOKEN = "artifacts-credential-of-the-endpoint-tests"
AUTH = ArtifactsAuth(SecretStr(TOKEN))
HEADERS = {"Authorization": f"Bearer {TOKEN}"}


def _health() -> dict[str, Any]:
    return {"status": "ok", "skills": []}


async def test_masks_are_addressable_by_their_mask_ref() -> None:
    store = ArtifactStore("http://127.0.0.1:9112")
    refs = store.add("find", "/vision/find/detections", _frame(111), _result())
    app = build_app(store, _health, auth=AUTH)

    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app=app), base_url="http://t", headers=HEADERS
    ) as client:
        response = await client.get(refs[0]["path"])
        missing = await client.get("/masks/find/111/7.png")
        listing = await client.get("/skills/find/masks")

    assert refs[0]["url"] == "http://127.0.0.1:9112/masks/find/111/0.png"
    assert refs[0]["topic"] == "/vision/find/detections"
    assert refs[1] == {}
    assert response.status_code == 200
    assert response.headers["content-type"] == "image/png"
    mask = np.asarray(PILImage.open(io.BytesIO(response.content)))
    assert mask.shape == (48, 64)
    assert mask[15, 10] == 255
    assert mask[0, 0] == 0
    assert missing.status_code == 404
    assert missing.json()["error"] == "not_found"
    assert listing.json()["masks"][0]["stamp_ns"] == 111


async def test_overlays_are_rendered_on_request() -> None:
    def render(image: Any, result: SkillResult) -> Any:
        out = image.copy()
        out[:] = (255, 0, 0)
        return out

    store = ArtifactStore("http://127.0.0.1:9112", renderer=render)
    store.add("find", "/vision/find/detections", _frame(5), _result())
    app = build_app(store, _health, auth=AUTH)

    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app=app), base_url="http://t", headers=HEADERS
    ) as client:
        latest = await client.get("/overlays/find/latest.png")
        by_stamp = await client.get("/overlays/find/5.png")
        unknown = await client.get("/overlays/other/latest.png")

    assert latest.status_code == by_stamp.status_code == 200
    assert np.asarray(PILImage.open(io.BytesIO(latest.content)))[0, 0].tolist() == [255, 0, 0]
    assert unknown.status_code == 404


def test_memory_is_bounded_per_skill_and_freed_when_no_deleted_skill_is_kept() -> None:
    store = ArtifactStore(
        "http://127.0.0.1:9112", masks_per_skill=3, overlays_per_skill=1, deleted_skills_kept=0
    )
    for stamp in range(50):
        store.add("find", "/vision/find/detections", _frame(stamp), _result())

    kept = {ref["stamp_ns"] for ref in store.mask_refs("find")}
    assert kept == {47, 48, 49}
    assert store.mask_png("find", 0, 0) is None
    assert store.approx_bytes() == 3 * (48 * 64 // 8)
    store.retire("find")
    assert store.mask_refs("find") == []


def test_a_deleted_skills_masks_stay_addressable_until_later_deletions_push_them_out() -> None:
    store = ArtifactStore("http://127.0.0.1:9112", deleted_skills_kept=2)
    for skill in ("a", "b", "c"):
        store.add(skill, f"/vision/{skill}/detections", _frame(1), _result())

    store.retire("a")
    store.retire("b")
    assert store.mask_png("a", 1, 0) is not None  # still there after its skill was deleted
    store.retire("c")  # the third deletion pushes out the oldest

    assert store.mask_png("a", 1, 0) is None
    assert store.mask_png("b", 1, 0) is not None
    assert store.mask_png("c", 1, 0) is not None


def test_a_recreated_skill_is_no_longer_retired() -> None:
    store = ArtifactStore("http://127.0.0.1:9112", deleted_skills_kept=1)
    store.add("a", "/vision/a/detections", _frame(1), _result())
    store.retire("a")
    store.add("a", "/vision/a/detections", _frame(2), _result())  # created again
    store.add("b", "/vision/b/detections", _frame(1), _result())
    store.retire("b")
    store.retire("c")

    assert store.mask_png("a", 2, 0) is not None


def test_server_answers_healthz_on_loopback(tcp_port: int) -> None:
    store = ArtifactStore(f"http://127.0.0.1:{tcp_port}")
    server = ArtifactServer(build_app(store, _health, auth=ArtifactsAuth()), "127.0.0.1", tcp_port)
    server.start()
    try:
        wait_for_tcp_port(tcp_port, 5.0)
        response = httpx.get(f"http://127.0.0.1:{tcp_port}/healthz", timeout=5.0)
    finally:
        server.stop()

    assert response.json() == {"status": "ok", "skills": []}
