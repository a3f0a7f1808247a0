"""The artifacts endpoint's pictures need the vision node's credential; /healthz stays open
(issue 35: ``/frames/latest.jpg`` answered any local process)."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
import pytest
import structlog
from pydantic import SecretStr

from robot_mcp_perception.artifacts import ArtifactStore, build_app
from robot_mcp_perception.artifacts_auth import ArtifactsAuth, artifacts_auth_from_env
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.pipelines.common import Detection, SkillResult
from robot_mcp_perception.settings import StartupError

TOKEN = "the-vision-nodes-artifacts-credential-0123"
PICTURES = (
    "/frames/latest.jpg",
    "/skills/find/masks",
    "/masks/find/7/0.png",
    "/overlays/find/latest.png",
    "/overlays/find/7.png",
)


def _app(auth: ArtifactsAuth) -> Any:
    store = ArtifactStore("http://127.0.0.1:9112")
    mask = np.zeros((48, 64), dtype=bool)
    mask[5:10, 5:10] = True
    frame = Frame(np.full((48, 64, 3), 90, np.uint8), 7, "cam", 1)
    store.add("find", "/vision/find/detections", frame, SkillResult(
        detections=[Detection("mug", 0.9, "object", (5, 5, 10, 10), mask, (7, 7))]
    ))  # fmt: skip
    return build_app(store, lambda: {"status": "ok"}, lambda: frame, auth=auth)


async def _get(app: Any, path: str, authorization: str | None = None) -> httpx.Response:
    headers = {"Authorization": authorization} if authorization is not None else {}
    async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://t") as c:
        return await c.get(path, headers=headers)


@pytest.mark.parametrize("path", PICTURES)
async def test_a_picture_without_the_credential_is_refused_with_401(path: str) -> None:
    app = _app(ArtifactsAuth(SecretStr(TOKEN)))
    with structlog.testing.capture_logs() as logs:
        missing = await _get(app, path)
        wrong = await _get(app, path, "Bearer " + "x" * 40)
        basic = await _get(app, path, f"Basic {TOKEN}")
        allowed = await _get(app, path, f"bearer {TOKEN}")

    assert missing.status_code == wrong.status_code == basic.status_code == 401
    assert missing.headers["www-authenticate"] == 'Bearer realm="vision"'
    assert 'error="invalid_token"' in wrong.headers["www-authenticate"]
    assert missing.json()["error"] == "unauthorized"
    assert allowed.status_code == 200, allowed.text
    refusals = [e for e in logs if e["event"] == "artifacts_auth_rejected"]
    assert [e["reason"] for e in refusals] == ["missing", "invalid", "missing"]
    assert TOKEN not in repr(logs)


async def test_healthz_stays_open_and_a_node_without_a_credential_serves_no_picture() -> None:
    app = _app(ArtifactsAuth())

    health = await _get(app, "/healthz")
    frame = await _get(app, "/frames/latest.jpg", f"Bearer {TOKEN}")

    assert health.status_code == 200
    assert frame.status_code == 401
    assert "ARTIFACTS_AUTH_TOKEN" in frame.json()["detail"]


async def test_artifacts_auth_off_opens_the_pictures() -> None:
    assert (await _get(_app(ArtifactsAuth(open=True)), "/frames/latest.jpg")).status_code == 200


def test_the_credential_comes_from_the_environment() -> None:
    assert artifacts_auth_from_env({}) == ArtifactsAuth()
    assert artifacts_auth_from_env({"ARTIFACTS_AUTH": "off"}).open
    configured = artifacts_auth_from_env({"ARTIFACTS_AUTH_TOKEN": f" {TOKEN} "})
    assert configured.check(f"Bearer {TOKEN}") == "ok"
    assert TOKEN not in repr(configured)


@pytest.mark.parametrize(
    ("env", "named"),
    [
        ({"ARTIFACTS_AUTH_TOKEN": "short"}, "at least 32"),
        ({"ARTIFACTS_AUTH": "off", "ARTIFACTS_AUTH_TOKEN": TOKEN}, "remove one"),
        ({"ARTIFACTS_AUTH": "maybe"}, "'required' or 'off'"),
    ],
)
def test_a_bad_credential_setting_refuses_to_start(env: dict[str, str], named: str) -> None:
    with pytest.raises(StartupError, match=named) as refused:
        artifacts_auth_from_env(env)
    assert TOKEN not in str(refused.value)
