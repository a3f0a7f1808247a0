"""The skill engine: decides per skill and frame whether to run, reuse or republish stale.

ROS-free. The node feeds it frames (``dispatch``) and gives it a :class:`ResultSink`; model
work goes through the :class:`~robot_mcp_perception.scheduler.Scheduler`. Rules:

- per-skill ``rate_hz`` (default: the node's processing_frequency), newest frame only; a
  new skill runs at once, later runs are phase-spread over the period; skills run on frame
  arrival (``dispatch``), the timer (``tick``) only when frames stop or a skill waited long;
- §8 cost policy for cloud stages (once / gate / per-skill cloud rate / global budget),
  metered per request: a run reserves all the cloud requests it will send (segment_all: one
  per tile + one for its outputs) or is skipped whole before the first one;
- the scene unchanged behind the gate: a skill segmenting with a local segmenter segments the
  new frame with its last grounding (marked ``grounding_reused``), others republish their
  last result stale; a run skipped for rate or budget (the scene may have changed) always
  republishes the last result stale with its original stamp — never old boxes on a new frame;
- the frame-difference gate for watch skills and ambient_scene;
- a new or re-enabled skill's first run waits (at most ``fresh_frame_wait_s``) for a frame
  stamped after the engine took the skill up: "look now" is answered from a frame taken now;
- ``once`` publishes once then disables; ``prewarm`` grounds once into the prewarm cache;
- a failed or timed-out run leaves the skill running and republishes its last result stale;
  a skill that never had a result publishes an empty one saying the node *cannot see*
  (``cannot_see_reason``: the failure), never an empty "nothing found";
- behind a grounder chain with a local fallback (``models.chain``), a run refused by the
  cloud budget still runs: every cloud charge is refused, so the fallback answers and nothing
  is sent; each result says who answered (``grounder``, ``grounder_fallback``).
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import itertools
import math
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from functools import partial
from typing import Literal, Protocol

import structlog

from robot_mcp_perception.cost import (
    SKIP_BUDGET,
    SKIP_GATE,
    CostPolicy,
    PrewarmCache,
    RefusingMeter,
    RunMeter,
)
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.models import answers
from robot_mcp_perception.models.base import GroundingResult, Image, ModelError
from robot_mcp_perception.models.chain import FallbackGrounder
from robot_mcp_perception.models.metering import CloudBudgetExhaustedError, metered
from robot_mcp_perception.pipelines.common import PipelineContext, SkillResult
from robot_mcp_perception.provenance import Provenance
from robot_mcp_perception.registry import Gate, GroundingSource, SkillRegistry, SkillState
from robot_mcp_perception.scheduler import JobTimeoutError, Scheduler
from robot_mcp_perception.skills import Skill

logger = structlog.get_logger("robot_mcp_perception.engine")

_GOLDEN_RATIO = 0.6180339887498949
_MAX_FRAME_INTERVAL_S = 5.0

SkillRunner = Callable[
    [Skill, Image, PipelineContext, GroundingResult | None], Awaitable[SkillResult]
]


CloudRequests = Callable[[Skill], int]
"""How many grounder requests one run of a skill sends (``pipelines.grounder_requests``)."""


class ResultSink(Protocol):
    def publish(
        self, state: SkillState, frame: Frame, result: SkillResult, provenance: Provenance
    ) -> None: ...


@dataclass(frozen=True)
class TickPlan:
    action: Literal["run", "stale"]
    reuse: GroundingSource | None = None
    reason: str = ""
    cloud_skipped: bool = False
    meter: RunMeter | RefusingMeter | None = None


class SkillEngine:
    def __init__(
        self,
        *,
        registry: SkillRegistry,
        scheduler: Scheduler,
        policy: CostPolicy,
        prewarm: PrewarmCache,
        context: PipelineContext,
        runner: SkillRunner,
        sink: ResultSink,
        default_rate_hz: float,
        scene_reference: Callable[[], Gate] | None = None,
        clock: Callable[[], float] = time.monotonic,
        grounder_requests: CloudRequests = lambda skill: 1,
        fresh_frame_wait_s: float = 0.0,
        wall_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self.registry = registry
        self.scheduler = scheduler
        self.policy = policy
        self.prewarm = prewarm
        self.context = context
        self.runner = runner
        self.sink = sink
        self.default_rate_hz = default_rate_hz
        self.scene_reference = scene_reference
        """Builds an unseeded frame-difference gate: the prewarm cache's scene check."""
        self.fresh_frame_wait_ns = int(fresh_frame_wait_s * 1e9)
        self._wall_ns = wall_ns
        self._taken_up_ns: dict[str, int] = {}
        """Wall ns at which each skill awaiting its first run was first seen (fresh-frame rule)."""
        self._clock = clock
        self.grounder_requests = grounder_requests
        self.lock = threading.RLock()
        self.grounder_cloud = context.grounder.cost_class == "cloud"
        chain = context.grounder
        self.local_fallback = (
            isinstance(chain, FallbackGrounder) and chain.fallback.cost_class == "local"
        )
        """A run the cloud budget refuses can still be answered on board."""
        self.segmenter_cloud = context.segmenter.cost_class == "cloud"
        self.out_of_order_dropped = 0
        self._phases = itertools.count()
        self._last_arrival: float | None = None
        self._frame_interval: float | None = None
        """Moving average of the time between frame arrivals (s)."""

    def _next_phase(self) -> float:
        """Phase offset (fraction of a period) of the next started skill: the golden-ratio
        sequence 0, .62, .24, .85, … spreads skills created together over their period, so
        they do not all fall due on the same frame and queue behind each other."""
        return (next(self._phases) * _GOLDEN_RATIO) % 1.0

    def period_s(self, skill: Skill) -> float:
        return 1.0 / (skill.rate_hz or self.default_rate_hz)

    def needs_cloud(self, skill: Skill, reuse: GroundingResult | None = None) -> bool:
        grounder = self.grounder_cloud and reuse is None
        return grounder or (self.segmenter_cloud and skill.segments)

    def cloud_requests(self, skill: Skill) -> int:
        """Cloud requests one fresh run sends (a cloud segmenter's count is only known after
        grounding: one is reserved, the rest are charged as they are sent)."""
        requests = self.grounder_requests(skill) if self.grounder_cloud else 0
        if self.segmenter_cloud and skill.segments:
            requests += 1
        return requests

    def dispatch(self, frame: Frame | None) -> None:
        """A new frame arrived: run every enabled skill that is due on it."""
        if frame is None:
            return
        with self.lock:
            now = self._clock()
            if self._last_arrival is not None:
                gap = min(now - self._last_arrival, _MAX_FRAME_INTERVAL_S)
                previous = self._frame_interval
                self._frame_interval = gap if previous is None else 0.8 * previous + 0.2 * gap
            self._last_arrival = now
            self._run_due(frame, now, arrival=True)

    def tick(self, frame: Frame | None) -> None:
        """Timer: run due skills on the newest frame when no newer frame is coming soon.

        While frames arrive regularly a due skill waits (at most half its period) for the
        next frame instead of processing the current one, which may be almost a frame
        interval old; a new or re-enabled skill never waits.
        """
        if frame is None:
            return
        with self.lock:
            self._run_due(frame, self._clock(), arrival=False)

    def _next_frame_expected(self, now: float) -> bool:
        interval, last = self._frame_interval, self._last_arrival
        return interval is not None and last is not None and now - last < 1.5 * interval

    def _run_due(self, frame: Frame, now: float, *, arrival: bool) -> None:
        wait_for_frame = not arrival and self._next_frame_expected(now)
        for state in self.registry.states():
            if state.enabled and not state.once_pending:
                self._maybe_run(state, frame, now, wait_for_frame)

    def _maybe_run(self, state: SkillState, frame: Frame, now: float, wait: bool) -> None:
        if now < state.next_due:
            return
        if state.next_due == 0.0 and self._older_than_skill(state, frame):
            return
        period = self.period_s(state.skill)
        newer_soon = wait or frame.seq == state.last_seq
        if newer_soon and state.next_due != 0.0 and now < state.next_due + period / 2:
            return  # wait a little for a newer frame before processing an old one
        if state.next_due == 0.0:  # first run since created / enabled: now, then phase in
            state.next_due = now + period * (1.0 + self._next_phase())
        elif state.next_due <= now - period:  # late: skip the missed runs, keep the phase
            state.next_due += period * (math.floor((now - state.next_due) / period) + 1)
        else:  # keep the phase (the rate stays exact despite frame jitter)
            state.next_due += period
        plan = self.plan(state, frame)
        if plan.reason:
            state.skips[plan.reason] += 1
        if plan.cloud_skipped:
            logger.warning("cloud_call_skipped", skill=state.skill.name, reason=plan.reason)
        if plan.action == "run":
            self._submit(state, frame, plan)
        else:
            self._republish_stale(state, plan.reason, frame)

    def _older_than_skill(self, state: SkillState, frame: Frame) -> bool:
        """The frame was captured before the skill was taken up, and the wait is not over."""
        if self.fresh_frame_wait_ns <= 0:
            return False
        name = state.skill.name
        wall = self._wall_ns()
        taken_up = self._taken_up_ns.setdefault(name, wall)
        if frame.stamp_ns >= taken_up or wall - taken_up >= self.fresh_frame_wait_ns:
            del self._taken_up_ns[name]
            return False
        return True

    def plan(self, state: SkillState, frame: Frame) -> TickPlan:
        """The §8 decision for this tick (side effects: gate reference, cloud reservation)."""
        skill = state.skill
        if state.runs == 0 and state.grounding is None and not skill.prewarm:
            cached = self.prewarm.lookup(skill, frame.image)
            if cached is not None:
                state.grounding = cached
                if state.gate is not None:
                    state.gate.passes(frame.image)  # the cached grounding is for this scene
                logger.info("prewarm_hit", skill=skill.name)
                return TickPlan("run", reuse=cached)
        cloud = self.needs_cloud(skill)
        gate = state.gate
        gated = (
            gate is not None
            and (
                skill.watch is not None
                or state.always_gated
                or (cloud and self.policy.needs_gate(skill))
            )
            and not (skill.once or skill.prewarm)
        )
        if gated and gate is not None and not gate.passes(frame.image):
            return self._scene_unchanged(state, cloud)
        if not cloud:
            return TickPlan("run")
        decision = self.policy.reserve(skill, self.cloud_requests(skill))
        if not decision.allowed and decision.reason == SKIP_BUDGET and self.local_fallback:
            logger.warning("cloud_call_skipped", skill=skill.name, reason=SKIP_BUDGET)
            return TickPlan("run", meter=RefusingMeter())
        if not decision.allowed:
            if gated and gate is not None:
                gate.reset()  # the change the gate saw still has to be grounded
            return TickPlan("stale", reason=decision.reason, cloud_skipped=True)
        return TickPlan("run", meter=decision.meter)

    def _scene_unchanged(self, state: SkillState, cloud: bool) -> TickPlan:
        """Behind the gate the scene is the one last grounded: a local segmenter may segment
        this frame with that grounding; anything else republishes the last result stale."""
        reusable = (
            state.grounding is not None
            and state.skill.segments
            and self.grounder_cloud
            and not self.segmenter_cloud
        )
        if reusable:
            return TickPlan("run", reuse=state.grounding, reason=SKIP_GATE, cloud_skipped=cloud)
        return TickPlan("stale", reason=SKIP_GATE, cloud_skipped=cloud)

    def _submit(self, state: SkillState, frame: Frame, plan: TickPlan) -> None:
        skill = state.skill
        to_run = dataclasses.replace(skill, segment=False) if skill.prewarm else skill
        state.last_seq = frame.seq
        state.once_pending = skill.once or skill.prewarm
        context, runner, meter = self.context, self.runner, plan.meter
        reuse = plan.reuse.grounding if plan.reuse is not None else None

        async def run() -> SkillResult:
            with metered(meter), answers.recording() as notes:
                result = await runner(to_run, frame.image, context, reuse)
            result.grounded_by = answers.marks(notes)
            return result

        future = self.scheduler.submit(skill.name, run)
        if future is None:
            state.once_pending = False
            state.skips["overloaded"] += 1
            if meter is not None:
                meter.close()
            return
        state.in_flight += 1
        future.add_done_callback(partial(self._on_done, state, frame, plan))

    def _on_done(
        self,
        state: SkillState,
        frame: Frame,
        plan: TickPlan,
        future: concurrent.futures.Future[SkillResult],
    ) -> None:
        if plan.meter is not None:
            plan.meter.close()
        with self.lock:
            state.in_flight -= 1
            if future.cancelled():
                state.once_pending = False
                state.skips["dropped"] += 1
                return
            if self.registry.find(state.skill.name) is not state:
                return  # deleted while running
            error = future.exception()
            if error is not None:
                self._on_failure(state, error, frame)
                return
            self._on_result(state, frame, plan.reuse, future.result())

    def _on_failure(self, state: SkillState, error: BaseException, frame: Frame) -> None:
        state.failures += 1
        state.consecutive_failures += 1
        state.last_error = str(error) or type(error).__name__
        state.once_pending = False
        if state.gate is not None:
            state.gate.reset()
        if isinstance(error, JobTimeoutError):
            reason = "model_timeout"
        elif isinstance(error, CloudBudgetExhaustedError):
            reason = SKIP_BUDGET
        else:
            reason = "model_error"
        logger.warning(
            "skill_run_failed",
            skill=state.skill.name,
            reason=reason,
            error=str(error) or type(error).__name__,
            error_type=type(error).__name__,
        )
        if state.last_result is None:
            self._cannot_see(state, reason, error, frame)
            return
        self._republish_stale(state, reason, frame)

    def _cannot_see(
        self, state: SkillState, reason: str, error: BaseException, frame: Frame
    ) -> None:
        """No result to fall back on: say the node could not look, with the failure's kind
        (a model error's ``kind``; ``timeout`` for a job past its limit)."""
        if isinstance(error, ModelError):
            kind: str = error.kind
        elif isinstance(error, JobTimeoutError):
            kind = "timeout"
        else:
            kind = "error"
        provenance = Provenance(
            stale_reason=reason, checked_stamp_ns=frame.stamp_ns, cannot_see=kind
        )
        logger.warning("skill_cannot_see", skill=state.skill.name, reason=kind)
        self.sink.publish(state, frame, SkillResult(), provenance)

    def _on_result(
        self, state: SkillState, frame: Frame, reuse: GroundingSource | None, result: SkillResult
    ) -> None:
        skill = state.skill
        state.runs += 1
        state.consecutive_failures = 0
        if result.grounding is not None and reuse is None:
            state.grounding = GroundingSource(
                result.grounding, frame.stamp_ns, frame.frame_id, result.grounded_by
            )
        if skill.prewarm:
            if result.grounding is not None:
                source = GroundingSource(
                    result.grounding, frame.stamp_ns, frame.frame_id, result.grounded_by
                )
                self.prewarm.put(skill, source, self._scene_of(frame))
            state.enabled = False
            state.once_pending = False
            logger.info("prewarm_cached", skill=skill.name, ttl_s=self.prewarm.ttl_s)
            return
        if frame.stamp_ns < state.last_published_stamp_ns:
            self.out_of_order_dropped += 1
            return
        provenance = (
            Provenance(grounded_by=result.grounded_by)
            if reuse is None
            else Provenance(
                grounding_stamp_ns=reuse.stamp_ns,
                grounding_frame_id=reuse.frame_id,
                grounded_by=reuse.grounded_by,
            )
        )
        state.last_result, state.last_frame, state.last_provenance = result, frame, provenance
        self.sink.publish(state, frame, result, provenance)
        if skill.once:
            state.enabled = False
            state.once_pending = False
            logger.info("skill_once_done", skill=skill.name)

    def _scene_of(self, frame: Frame) -> Gate | None:
        if self.scene_reference is None:
            return None
        scene = self.scene_reference()
        scene.passes(frame.image)  # the first frame seeds the reference
        return scene

    def _republish_stale(self, state: SkillState, reason: str, checked: Frame) -> None:
        """The last result again, with its original stamp, marked stale (``checked``: the
        frame whose run was skipped or failed)."""
        if state.last_result is None or state.last_frame is None:
            return
        provenance = state.last_provenance.stale_copy(reason, checked.stamp_ns)
        self.sink.publish(state, state.last_frame, state.last_result, provenance)
