"""SkillEngine scheduling with a fake clock: rates, phase spreading, waiting for a new frame."""

from __future__ import annotations

import concurrent.futures
from collections import Counter
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.cost import CostPolicy, PrewarmCache
from robot_mcp_perception.engine import SkillEngine
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext
from robot_mcp_perception.registry import SkillRegistry, SkillState, topics_for
from robot_mcp_perception.settings import CostSettings
from robot_mcp_perception.skills import Skill

FRAME_S = 1.0 / 30.0


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class RecordingScheduler:
    """Records submissions (skill name, newest frame seq); the jobs never finish."""

    def __init__(self, engine_frames: list[int]) -> None:
        self.submitted: list[tuple[str, int]] = []
        self.on_tick: list[str] = []
        self.in_tick = False
        self._frames = engine_frames

    def submit(self, key: str, factory: Any) -> concurrent.futures.Future[Any]:
        self.submitted.append((key, self._frames[-1]))
        if self.in_tick:
            self.on_tick.append(key)
        return concurrent.futures.Future()


class Rig:
    def __init__(self, *names: str, rate_hz: float = 5.0, fresh_frame_wait_s: float = 0.0) -> None:
        self.clock = Clock()
        self.registry = SkillRegistry()
        self.seqs: list[int] = [0]
        self.scheduler = RecordingScheduler(self.seqs)
        self.engine = SkillEngine(
            registry=self.registry,
            scheduler=self.scheduler,  # type: ignore[arg-type]
            policy=CostPolicy(CostSettings(), self.clock),
            prewarm=PrewarmCache(60.0, self.clock),
            context=PipelineContext(FakeGrounder(cost_class="local"), NullSegmenter()),
            runner=run_skill,
            sink=self,
            default_rate_hz=rate_hz,
            clock=self.clock,
            fresh_frame_wait_s=fresh_frame_wait_s,
            wall_ns=lambda: int(self.clock.now * 1e9),
        )
        self.image = np.zeros((48, 64, 3), dtype=np.uint8)
        for name in names:
            self.add(name, rate_hz)

    def add(self, name: str, rate_hz: float) -> None:
        skill = Skill(name=name, mode="describe", rate_hz=rate_hz)
        self.registry.add(SkillState(skill, topics_for("/vision", skill)))

    def publish(self, *args: Any) -> None:
        raise AssertionError("the recording scheduler never finishes a job")

    def frame(self) -> Frame:
        seq = self.seqs[-1] + 1
        self.seqs.append(seq)
        self.engine.dispatch(Frame(self.image, int(self.clock.now * 1e9), "camera", seq))
        return self.latest()

    def latest(self) -> Frame:
        return Frame(self.image, int(self.clock.now * 1e9), "camera", self.seqs[-1])

    def play(self, seconds: float, tick_every: int = 0) -> None:
        """Frames at 30 Hz (and ``tick_every`` engine ticks between two frames)."""
        for _ in range(round(seconds / FRAME_S)):
            self.frame()
            for _ in range(tick_every):
                self.clock.now += FRAME_S / (tick_every + 1)
                self.tick()
            self.clock.now += FRAME_S / (tick_every + 1)

    def tick(self) -> None:
        self.scheduler.in_tick = True
        try:
            self.engine.tick(self.latest())
        finally:
            self.scheduler.in_tick = False

    def runs(self) -> Counter[str]:
        return Counter(name for name, _ in self.scheduler.submitted)


def test_skills_created_together_run_at_once_then_spread_over_their_period() -> None:
    rig = Rig("a", "b", "c", "d")

    rig.frame()
    assert rig.runs() == Counter({"a": 1, "b": 1, "c": 1, "d": 1})
    rig.play(1.0)  # the second runs are phased in
    rig.scheduler.submitted.clear()
    rig.play(2.0)

    assert rig.runs() == Counter({"a": 10, "b": 10, "c": 10, "d": 10})  # 5 Hz each
    per_frame = Counter(seq for _, seq in rig.scheduler.submitted)
    assert max(per_frame.values()) == 1


def test_a_due_skill_waits_for_the_next_frame_while_frames_keep_coming() -> None:
    rig = Rig("a")
    rig.frame()
    rig.scheduler.submitted.clear()

    rig.play(2.0, tick_every=3)

    assert len(rig.scheduler.submitted) == 9  # 5 Hz after the phase-0 first run
    assert rig.scheduler.on_tick == []  # each ran on a new frame, as it arrived


def test_ticks_run_due_skills_on_the_last_frame_when_frames_stop() -> None:
    rig = Rig("a")
    rig.play(0.5)
    submitted = len(rig.scheduler.submitted)

    for _ in range(50):  # 1 s of ticks, no frames
        rig.clock.now += 0.02
        rig.tick()

    assert len(rig.scheduler.submitted) - submitted >= 2
    assert rig.scheduler.on_tick


def test_a_new_skill_starts_on_a_tick_without_waiting_for_a_frame() -> None:
    rig = Rig("a")
    rig.play(0.5)
    rig.add("fresh", 5.0)

    rig.clock.now += 0.005
    rig.tick()

    assert rig.scheduler.on_tick == ["fresh"]


def test_a_late_skill_skips_missed_runs_but_keeps_its_phase() -> None:
    rig = Rig("a")
    rig.frame()
    state = rig.registry.get("a")
    first_due = state.next_due

    rig.clock.now += 0.75  # no frame for more than three periods
    rig.frame()

    assert len(rig.scheduler.submitted) == 2
    assert state.next_due == pytest.approx(first_due + 3 * 0.2)
    assert state.next_due > rig.clock.now


def test_a_new_skill_first_looks_at_a_frame_taken_after_it_was_taken_up() -> None:
    """Started on arrival, "look" never answers from the frame seen while driving."""
    rig = Rig(fresh_frame_wait_s=1.0)
    rig.play(0.2)  # frames keep coming; no skill yet
    rig.add("look", 5.0)
    rig.clock.now += 0.01
    stale = Frame(rig.image, int((rig.clock.now - 0.3) * 1e9), "camera", rig.seqs[-1] + 1)
    rig.seqs.append(stale.seq)
    rig.engine.dispatch(stale)  # captured before the skill existed (still in flight)
    assert rig.scheduler.submitted == []
    rig.frame()  # captured now
    assert rig.scheduler.submitted == [("look", rig.seqs[-1])]


def test_the_fresh_frame_wait_is_bounded_for_cameras_whose_stamps_lag() -> None:
    rig = Rig(fresh_frame_wait_s=0.5)
    rig.add("look", 5.0)
    for _ in range(40):  # 30 Hz frames stamped 10 s in the past
        rig.seqs.append(rig.seqs[-1] + 1)
        rig.engine.dispatch(
            Frame(rig.image, int((rig.clock.now - 10) * 1e9), "camera", rig.seqs[-1])
        )
        rig.clock.now += FRAME_S
    assert len(rig.scheduler.submitted) >= 1  # ran after the wait, on the newest frame
    first_seq = rig.scheduler.submitted[0][1]
    assert 15 <= first_seq <= 17  # 0.5 s of 30 Hz frames went by first
