"""The watch pipeline: the frame-difference gate and gated runs of a watcher skill."""

from __future__ import annotations

import numpy as np
import pytest

from robot_mcp_perception.models.base import GroundingResult, ModelError
from robot_mcp_perception.models.fakes import FakeGrounder, FakeSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext, SkillModeError, SkillResult
from robot_mcp_perception.pipelines.watch import FrameDiffGate, watched_value
from robot_mcp_perception.skills import Skill, SkillOutput, WatchSpec


def frame(value: int, square: bool = False) -> np.ndarray:
    image = np.full((60, 80, 3), value, np.uint8)
    if square:
        image[10:40, 20:60] = 255
    return image


WATCHER = Skill(
    "mug_watch",
    "describe",
    grounding="is there a mug",
    outputs=(SkillOutput("present", "boolean"),),
    watch=WatchSpec("present"),
)


def test_the_first_frame_always_passes_and_an_identical_one_does_not() -> None:
    gate = FrameDiffGate(threshold=0.02)
    assert gate.passes(frame(40))
    assert not gate.passes(frame(40))
    assert gate.last_difference == 0.0


def test_a_changed_frame_passes_and_becomes_the_new_reference() -> None:
    gate = FrameDiffGate(threshold=0.02)
    gate.passes(frame(40))
    assert gate.passes(frame(40, square=True))
    assert gate.last_difference is not None
    assert gate.last_difference > 0.02
    assert not gate.passes(frame(40, square=True))


def test_small_noise_stays_below_the_threshold_but_slow_drift_adds_up() -> None:
    gate = FrameDiffGate(threshold=0.02)
    gate.passes(frame(100))
    rng = np.random.default_rng(0)
    noisy = np.clip(frame(100).astype(int) + rng.integers(-3, 4, (60, 80, 3)), 0, 255).astype(
        np.uint8
    )
    assert not gate.passes(noisy)
    assert not gate.passes(frame(103))
    assert gate.passes(frame(107))  # compared with the last *passed* frame (value 100)


def test_reset_makes_the_next_frame_pass() -> None:
    gate = FrameDiffGate()
    gate.passes(frame(40))
    gate.reset()
    assert gate.last_difference is None
    assert gate.passes(frame(40))
    assert gate.difference(frame(40)) == 0.0
    assert FrameDiffGate().difference(frame(40)) == 1.0


def test_bad_gate_settings_and_images_are_refused() -> None:
    with pytest.raises(ValueError, match=r"0\.\.1"):
        FrameDiffGate(threshold=2.0)
    with pytest.raises(ValueError, match="thumb_size"):
        FrameDiffGate(thumb_size=(0, 1))
    with pytest.raises(ValueError, match="RGB"):
        FrameDiffGate().passes(np.zeros((4, 4), np.uint8))


async def test_the_router_publishes_a_watchers_output_as_a_boolean() -> None:
    grounder = FakeGrounder(GroundingResult(outputs={"present": "yes"}))
    ctx = PipelineContext(grounder, FakeSegmenter())

    result = await run_skill(WATCHER, frame(40), ctx)

    assert result.outputs == {"present": True}


async def test_a_watcher_run_without_its_watched_boolean_is_a_model_error() -> None:
    ctx = PipelineContext(FakeGrounder(GroundingResult(outputs={})), FakeSegmenter())
    with pytest.raises(ModelError, match="missing"):
        await run_skill(WATCHER, frame(1), ctx)
    with pytest.raises(ModelError, match="not a boolean"):
        watched_value(WATCHER, SkillResult(outputs={"present": "perhaps"}))


def test_watched_value_needs_a_watch_block() -> None:
    with pytest.raises(SkillModeError, match="no watch block"):
        watched_value(Skill("s", "describe"), SkillResult())
