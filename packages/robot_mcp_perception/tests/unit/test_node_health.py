"""/healthz reports the node's real state and answers 503 when degraded (issue 13 item 5)."""

from __future__ import annotations

from typing import Any

import httpx
import pytest

from robot_mcp_perception.models.base import GroundingResult
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros


class SwitchableGrounder(FakeGrounder):
    def __init__(self) -> None:
        super().__init__(GroundingResult(answer="ok"))
        self.problem: str | None = None

    def readiness(self) -> str | None:
        return self.problem


def test_healthz_reports_frame_age_models_and_skills_and_is_503_when_degraded(
    start_node: Any, settings_factory: Any, scene_factory: Any, tcp_port: int
) -> None:
    settings = settings_factory(
        artifacts={"enabled": True, "port": tcp_port}, node={"frame_stale_after_s": 1.0}
    )
    grounder = SwitchableGrounder()
    harness = start_node(settings=settings, grounder=grounder, serve_artifacts=True)
    url = f"http://127.0.0.1:{tcp_port}/healthz"

    def get() -> httpx.Response:
        return httpx.get(url, timeout=5.0)

    before = get()
    assert before.status_code == 503
    assert before.json()["problems"] == ["no camera frame received yet"]

    harness.create({"name": "look", "mode": "describe", "rate_hz": 5})
    harness.source.push(scene_factory(40))
    healthy = get()
    assert healthy.status_code == 200, healthy.json()
    body = healthy.json()
    assert body["status"] == "ok"
    assert body["frame"]["age_s"] < 1.0
    assert body["models"]["grounder"] == {
        "adapter": "SwitchableGrounder",
        "cost_class": "cloud",
        "ready": True,
        "problem": None,
    }
    assert body["model_loop"]["running"] is True
    assert [s["name"] for s in body["skills"]] == ["look"]

    wait_until(lambda: get().status_code == 503, 10.0, "the frame to go stale")
    assert "the newest camera frame arrived" in get().json()["problems"][0]

    harness.source.push(scene_factory(40))
    grounder.problem = "Gemini refused the API key (HTTP 400)"
    refused = get()
    assert refused.status_code == 503
    assert refused.json()["problems"] == ["grounder: Gemini refused the API key (HTTP 400)"]
    assert refused.json()["models"]["grounder"]["ready"] is False
