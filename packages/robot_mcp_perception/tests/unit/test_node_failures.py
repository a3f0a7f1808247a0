"""A failing or hanging grounder never stops a skill (stale republish + WARN)."""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any

import pytest
import rclpy
from ros2_vision_interfaces.msg import VisionDetectionArray

from robot_mcp_perception.models.base import GroundingResult, Image, ModelError, SemanticRequest
from robot_mcp_perception.models.fakes import FakeGrounder

pytestmark = pytest.mark.ros

REGION = {"name": "spot", "mode": "region", "grounding": "free space", "rate_hz": 10}


class HangsAfterFirstCall(FakeGrounder):
    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        if self.calls:
            self.calls.append(self.calls[0])
            await asyncio.sleep(3600)
        return await super().ground(image, question, outputs, mode)


def _stale_reasons(messages: list[Any]) -> set[str]:
    reasons = set()
    for msg in messages:
        for det in msg.detections:
            extra = json.loads(det.extra)
            if extra.get("stale"):
                reasons.add(extra["reason"])
    return reasons


@pytest.mark.parametrize("failure", ["raises", "hangs"])
def test_grounder_that_raises_or_hangs_leaves_the_skill_running_and_republishes_stale(
    start_node: Any,
    settings_factory: Any,
    log_events: list[dict[str, Any]],
    mug_result: GroundingResult,
    failure: str,
) -> None:
    grounder = (
        FakeGrounder([mug_result, ModelError("quota exceeded")], cost_class="local")
        if failure == "raises"
        else HangsAfterFirstCall(mug_result, cost_class="local")
    )
    settings = settings_factory(node={"model_timeout_s": 0.3, "processing_frequency": 5.0})
    harness = start_node(grounder=grounder, settings=settings)
    meta = harness.probe.subscribe("/vision/spot/detections_meta", VisionDetectionArray)
    harness.create(REGION)
    reason = "model_error" if failure == "raises" else "model_timeout"

    harness.pump(lambda: reason in _stale_reasons(meta), what=f"a stale republish ({reason})")
    harness.pump(lambda: harness.node.registry.get("spot").failures >= 2, what="a retried failure")

    state = harness.node.registry.get("spot")
    assert state.enabled
    warnings = [e for e in log_events if e["event"] == "skill_run_failed"]
    assert warnings
    assert warnings[0]["log_level"] == "warning"
    assert warnings[0]["reason"] == reason
    fresh = next(m for m in meta if not _stale_reasons([m]))
    stale = next(m for m in meta if _stale_reasons([m]))
    assert stale.header.stamp == fresh.header.stamp
    ok, listing = harness.probe.call("list_vision_tasks", {})
    assert ok
    assert listing["skills"][0]["enabled"] is True


def test_a_model_run_cancelled_at_shutdown_publishes_nothing_after_the_context_is_gone(
    start_node: Any,
    settings_factory: Any,
    mug_result: GroundingResult,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A signal shuts the ROS context down first; then ``shutdown`` cancels the hanging run,
    whose failure republishes the last result as stale. That publish raised rcl's "context is
    invalid" inside a future's callback (a traceback in the node's output: the busy CI's
    skill_control integration test)."""
    grounder = HangsAfterFirstCall(mug_result, cost_class="local")
    settings = settings_factory(node={"model_timeout_s": 60.0, "processing_frequency": 5.0})
    harness = start_node(grounder=grounder, settings=settings)
    meta = harness.probe.subscribe("/vision/spot/detections_meta", VisionDetectionArray)
    harness.create(REGION)
    harness.pump(lambda: len(meta) >= 1 and len(grounder.calls) >= 2, what="a run left hanging")

    rclpy.shutdown(context=harness.node.context)  # what SIGINT/SIGTERM do first
    with caplog.at_level(logging.ERROR, logger="concurrent.futures"):
        harness.node.shutdown()
    assert not [r for r in caplog.records if "exception calling callback" in r.getMessage()]
