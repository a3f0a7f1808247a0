"""MissionExecutor (spec §5): one asyncio task per mission running the planner loop."""

from __future__ import annotations

import asyncio
import contextlib
import re
import time
from pathlib import Path

import structlog

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.abort import abort_run, busy_note, is_abort
from robot_voice_chat.agent.archive import MissionArchive
from robot_voice_chat.agent.bargein import BargeIn
from robot_voice_chat.agent.dispatch import TaskDispatcher
from robot_voice_chat.agent.holding import HeldAtStart, picked_last, tell_what_is_held
from robot_voice_chat.agent.memory import MemoryClient
from robot_voice_chat.agent.mission import Mission, MissionStore
from robot_voice_chat.agent.output import MissionOutput
from robot_voice_chat.agent.plan_tools import DEFINITIONS, PlanTools, inject_step_id
from robot_voice_chat.agent.prompt import load_prompt, system_prompt
from robot_voice_chat.agent.recovery import close_interrupted
from robot_voice_chat.agent.run import (
    MissionBusyError,
    MissionFailure,
    MissionRun,
    MissionsDisabledError,
    SafetyStopLatchedError,
)
from robot_voice_chat.agent.skills import SkillLedger
from robot_voice_chat.agent.task_registry import TaskRegistry
from robot_voice_chat.agent.teaching import Teaching
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.approvals import ApprovalBroker, PendingApproval
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch, acting, latched_sentence
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import plain_instruction
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.llm.base import (
    USER_TURN_PREFIX,
    LLMError,
    LLMProvider,
    LLMResponse,
    Message,
    ToolCall,
    ToolDefinition,
    ToolResult,
)
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.settings import AgentConfig
from robot_voice_chat.socket_events import MissionFinished, MissionStarted

logger = structlog.get_logger(__name__)
# the answers to "Should I continue or abort?" that end a paused mission
_ABORT = re.compile(r"\b(?:abort|cancel|give up|forget it|never ?mind|quit|no|nope|end it)\b")


class MissionExecutor:
    """Singleton built by the composition root; see spec §5 for the loop."""

    def __init__(
        self,
        *,
        planner: LLMProvider | None,
        tools: ToolBackend,
        emitter: EventEmitter,
        speech: SpeechOutput,
        memory: MemoryClient,
        trace: TraceRecorder,
        teaching: Teaching,
        config: AgentConfig,
        prompt_path: Path,
        store: MissionStore | None = None,
        registry: TaskRegistry | None = None,
        archive: MissionArchive | None = None,
        latch: SafetyLatch | None = None,
        approvals: ApprovalBroker | None = None,
        supervisor: MotionSupervisor | None = None,
    ) -> None:
        self.planner = planner
        self.supervisor = supervisor
        self.tools = tools
        self.emitter = emitter
        self.speech = speech
        self.memory = memory
        self.trace = trace
        self.teaching = teaching
        self.config = config
        self.prompt_path = prompt_path
        self.store = store or MissionStore()
        self.registry = registry or TaskRegistry()
        self.archive = archive
        # the composition root passes the persisted latch; alone, one for this process life
        self.latch = latch or SafetyLatch(MemoryLatchStore())
        self.approvals = approvals
        if approvals is not None:
            approvals.add_state_hook(self._awaiting_approval)
        self.output = MissionOutput(emitter, speech, trace, archive)
        self.held_at_start = HeldAtStart(tools, speech, emitter, config.tool_timeout_s)
        self.plan_tools = PlanTools(
            on_plan=self.output.emit_plan,
            on_say=self.output.say,
            vet_reaction=tools.vet_reaction if isinstance(tools, GuardedToolBackend) else None,
        )
        self.run: MissionRun | None = None
        self._starting = asyncio.Lock()
        self.dispatcher = TaskDispatcher(
            tools=tools,
            registry=self.registry,
            trace=trace,
            config=config,
            output=self.output,
            plan_tools=self.plan_tools,
            current_run=lambda: self.run,
            latched=lambda: self.latch.latched,
            supervisor=supervisor,
        )
        self.bargein = BargeIn(
            tools=tools,
            registry=self.registry,
            trace=trace,
            config=config,
            speech=speech,
            output=self.output,
            dispatcher=self.dispatcher,
            current_run=lambda: self.run,
            latch=self.latch,
            approvals=approvals,
            supervisor=supervisor,
        )

    @property
    def enabled(self) -> bool:
        return self.config.enabled and self.planner is not None

    @property
    def active(self) -> Mission | None:
        """The mission turns are routed into: none once it has finished, also while its end
        is still being told (a turn then is a new request, never news for a failed mission)."""
        run = self.run
        return run.mission if run is not None and run.finished is None else None

    # --- entry points -------------------------------------------------------------------
    async def start(self, instruction: str) -> Mission:
        if not self.enabled:
            raise MissionsDisabledError("missions are disabled (no planner configured)")
        # One mission at a time (§4) also under concurrent starts: the check and the
        # ``self.run = run`` below are one critical section, awaits in between included.
        async with self._starting:
            await self._wait_released()
            if self.run is not None:
                raise MissionBusyError(self.run.mission)
            self._refuse_if_latched(instruction)
            prompt = await load_prompt(self.prompt_path)
            self._refuse_if_latched(instruction)  # a stop may have come while the prompt loaded
            mission = Mission.new(instruction, teaching=await self.teaching.take())
            self.store.add(mission)
            await self.output.save(mission)
            run = MissionRun(mission=mission, prompt=prompt)
            self.run = run
        self.trace.record(
            mission.id, "instruction", instruction=instruction, teaching=mission.teaching
        )
        await self.emitter.emit(
            MissionStarted(
                mission_id=mission.id,
                instruction=instruction,
                teaching=mission.teaching,
                started_at=mission.created_at.timestamp(),
            )
        )
        with structlog.contextvars.bound_contextvars(mission_id=mission.id):
            logger.info("mission_started", instruction=instruction)
            run.task = asyncio.create_task(self._run(run), name=f"mission-{mission.id}")
        return mission

    async def _wait_released(self) -> None:
        """A mission that has finished but is still being told (its summary spoken) ends
        first; the new one starts after it (bounded: a stuck finalization stays busy)."""
        run = self.run
        if run is None or run.finished is None:
            return
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(self.config.tool_timeout_s):
                await run.released.wait()

    def _refuse_if_latched(self, instruction: str) -> None:
        if self.latch.latched:
            logger.warning("mission_refused", code="SAFETY_STOP_LATCHED", instruction=instruction)
            raise SafetyStopLatchedError(latched_sentence(self.latch.state))

    async def on_user_turn(self, text: str) -> str | None:
        """Route a turn into the mission (§5.1); returns the immediate answer for the
        person (the planner may add its own with ``say``), or None when the mission ended
        before the turn reached it (the caller treats it as a new request)."""
        run = self.run
        if run is None or run.finished is not None:
            return None
        mission = run.mission
        if self.is_stop(text):
            return await self.safety_stop(reason=f"user said {text!r}")
        if mission.state != "paused" and is_abort(text):  # heard at once, also over a question
            await self.output.log_line(run, "user_turn", text)
            return await abort_run(
                run,
                text=text,
                registry=self.registry,
                dispatcher=self.dispatcher,
                approvals=self.approvals,
            )
        if self.approvals is not None:  # a yes/no to the approval the mission waits for
            answer = self.approvals.answer_from_chat(text, run.mission.id, acting())
            if answer is not None:
                await self.output.log_line(run, "user_turn", text)
                await self.output.say(run, answer)  # spoken: the person may be talking
                return answer
        held = self._held_by_latch(run, text)
        if held is not None:
            await self.output.log_line(run, "user_turn", text)
            await self.output.say(run, held)
            return held
        await self.output.log_line(run, "user_turn", text)
        if run.finished is not None:  # it ended while the line was written
            return None
        self.trace.record(mission.id, "user_turn", text=text)
        run.awaiting_user = False
        if mission.state == "paused":
            run.post(f"{run.prompt.paused_note}\nUser: {text}")
            echoed = plain_instruction(mission.instruction)
            return f"Your answer went to the paused mission ({echoed})."
        run.post(f"{USER_TURN_PREFIX}{text}")
        return busy_note(mission, self.supervisor)

    def _held_by_latch(self, run: MissionRun, text: str) -> str | None:
        """While the software stop is latched a paused mission cannot go on: an answer other
        than an abort (continue, carry on, yes) is answered here and not passed on (issue 32)."""
        if not self.latch.latched or run.mission.state != "paused" or _ABORT.search(text.lower()):
            return None
        return (
            f"{latched_sentence(self.latch.state)} Once it is cleared, say continue, or say "
            "abort to end the mission."
        )

    def nothing_to_resume(self) -> str:
        """ "continue" with no mission running: nothing to resume, and why (issue 32)."""
        if self.latch.latched:
            return f"{latched_sentence(self.latch.state)} There is no paused mission to continue."
        return "There's nothing to continue: no mission is paused. Tell me what to do next."

    async def _awaiting_approval(self, request: PendingApproval, waiting: bool) -> None:
        """The mission shows ``awaiting_approval`` while one of its calls waits for a yes."""
        run = self.run
        if run is None or run.mission.id != request.context.mission_id:
            return
        mission = run.mission
        if waiting and mission.state in ("planning", "running"):
            mission.state = "awaiting_approval"
        elif not waiting and mission.state == "awaiting_approval":
            if not self.approvals or not self.approvals.pending(mission.id):
                mission.state = "running"
        else:
            return
        await self.output.emit_plan(run)

    # --- the loop (§5.2) ------------------------------------------------------------------
    async def _run(self, run: MissionRun) -> None:
        try:
            await self._prepare(run)
            while run.finished is None:
                if run.suspended:
                    await self._suspend(run)
                only_user_turns = self._drain(run)
                response = await self._llm_step(run, counted=not only_user_turns)
                if response is None or run.finished is not None:
                    continue
                await self._handle_response(run, response)
                await self.trace.flush()
        except MissionFailure as exc:
            logger.warning("mission_failed", code=exc.code, summary=exc.summary)
            run.finished = ("failed", exc.summary)
        except LLMError as exc:
            logger.warning("planner_failed", error=str(exc)[:500])
            run.finished = ("failed", "I had to stop the mission: my planner is not answering.")
        except asyncio.CancelledError:
            run.finished = run.finished or ("cancelled", "The mission was cancelled.")
            await self._finalize(run)
            raise
        except Exception:
            logger.exception("mission_crashed")
            run.finished = ("failed", "The mission stopped on an internal error.")
        await self._finalize(run)

    async def _prepare(self, run: MissionRun) -> None:
        mission = run.mission
        started = time.monotonic()
        processes = await self.memory.find_processes(mission.instruction, self.config.processes_k)
        mission.used_process_ids = [p.id for p in processes]
        logger.info(
            "processes_retrieved",
            ids=mission.used_process_ids,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        self.trace.record(
            mission.id, "processes", processes=[{"id": p.id, "score": p.score} for p in processes]
        )
        run.messages = [
            Message(role="system", content=system_prompt(run.prompt, processes)),
            Message(role="user", content=mission.instruction),
        ]

    def remaining_s(self, run: MissionRun) -> float:
        return self.config.max_wall_clock_s - (time.monotonic() - run.started)

    def _check_wall_clock(self, run: MissionRun) -> float:
        remaining = self.remaining_s(run)
        if remaining <= 0:
            raise MissionFailure(
                "BUDGET_WALL_CLOCK",
                f"Stopped: the mission exceeded its time budget of "
                f"{self.config.max_wall_clock_s:g} s.",
            )
        return remaining

    async def _suspend(self, run: MissionRun) -> None:
        while run.finished is None and (
            not run.inbox or (run.mission.state == "paused" and run.awaiting_user)
        ):
            timeout = min(self.config.wakeup_timeout_s, self._check_wall_clock(run))
            try:
                async with asyncio.timeout(timeout):
                    await run.wakeup.wait()
            except TimeoutError:
                self._check_wall_clock(run)
                # a task still reporting progress needs no planner call: keep waiting
                if run.mission.state != "paused" and not self.registry.progressed(
                    run.mission.id, within_s=timeout
                ):
                    snapshot = self.registry.snapshot(run.mission.id)
                    run.inbox.append(
                        f"[timeout] still waiting after {timeout:g} s; tasks: {snapshot}"
                    )
            run.wakeup.clear()
        run.suspended = False

    def _drain(self, run: MissionRun) -> bool:
        """Hand the inbox to the planner; True when it held nothing but the person's turns."""
        run.wakeup.clear()
        only_user_turns = bool(run.inbox) and all(
            line.startswith(USER_TURN_PREFIX) for line in run.inbox
        )
        if run.inbox:
            run.messages.append(Message(role="user", content="\n".join(run.inbox)))
            run.inbox.clear()
        return only_user_turns

    async def _llm_step(self, run: MissionRun, *, counted: bool = True) -> LLMResponse | None:
        """One planner call. ``counted=False``: a step the person's own turns woke (a burst of
        chat during a drive) does not use up the mission's step budget, which guards against a
        planner looping on its own; the time and cost budgets still bound it (issue 39)."""
        assert self.planner is not None
        remaining = self._check_wall_clock(run)
        if counted and run.llm_steps >= self.config.max_llm_steps:
            raise MissionFailure(
                "BUDGET_STEPS",
                f"Stopped: the mission used its budget of "
                f"{self.config.max_llm_steps} planner steps.",
            )
        run.llm_steps += 1 if counted else 0
        tools = self.planner_tools()
        started = time.monotonic()
        run.llm_call = asyncio.create_task(self.planner.chat(list(run.messages), tools))
        done, _ = await asyncio.wait({run.llm_call}, timeout=remaining)
        call, run.llm_call = run.llm_call, None
        if not done:
            call.cancel()
            self._check_wall_clock(run)
            raise MissionFailure("BUDGET_WALL_CLOCK", "Stopped: the time budget ran out.")
        if call.cancelled():  # a safety stop interrupted this step (§9)
            return None
        response = call.result()
        duration_ms = round((time.monotonic() - started) * 1000, 1)
        logger.info(
            "planner_step",
            step=run.llm_steps,
            tool_calls=[c.name for c in response.tool_calls],
            duration_ms=duration_ms,
        )
        self.trace.record(
            run.mission.id,
            "llm_step",
            step=run.llm_steps,
            request_messages=len(run.messages),
            request_chars=sum(len(m.content) for m in run.messages),
            tool_calls=[c.model_dump() for c in response.tool_calls],
            text=response.text,
            duration_ms=duration_ms,
            usage=response.usage.model_dump(),
        )
        run.mission.usage = run.mission.usage + response.usage
        if response.usage.cost_usd is not None:
            run.cost_usd += response.usage.cost_usd
            if self.config.max_cost_usd is not None and run.cost_usd > self.config.max_cost_usd:
                raise MissionFailure(
                    "BUDGET_COST",
                    f"Stopped: the cost budget of ${self.config.max_cost_usd:g} ran out.",
                )
        return response

    async def _handle_response(self, run: MissionRun, response: LLMResponse) -> None:
        run.messages.append(response.as_message())
        if response.tool_calls:
            results = await asyncio.gather(*(self.execute(run, c) for c in response.tool_calls))
            run.messages.append(Message(role="user", tool_results=list(results)))
            run.nudged = False
        elif self.registry.live(run.mission.id) or run.awaiting_user:
            run.suspended = True
        elif not run.nudged:
            run.nudged = True
            run.inbox.append(run.prompt.nudge)
        else:
            raise MissionFailure(
                "NO_PROGRESS",
                "Stopped: the planner made no progress (no tool calls and nothing pending).",
            )

    def planner_tools(self) -> list[ToolDefinition]:
        return DEFINITIONS + inject_step_id(self.tools.list_tools())

    # --- finalization (§5.6) ----------------------------------------------------------------
    async def _finalize(self, run: MissionRun) -> None:
        try:
            await self._close(run)
        finally:
            if self.run is run:
                self.run = None
            run.released.set()
        mission = run.mission
        outcome, summary = mission.state, mission.summary
        for process_id in mission.used_process_ids:
            await self.memory.record_outcome(process_id, outcome == "succeeded", summary[:500])
        self.trace.record(
            mission.id,
            "final",
            outcome=outcome,
            summary=summary,
            llm_steps=run.llm_steps,
            usage=mission.usage.model_dump(),
        )
        await self.trace.flush()
        if mission.teaching and self.planner is not None:
            records = await self.trace.read(mission.id)
            await self.teaching.distill_and_save(self.planner, run.prompt, records)

    async def _close(self, run: MissionRun) -> None:
        """End the mission's tasks, resolve its steps and tell its end (UI, speech)."""
        mission = run.mission
        run.finished = run.finished or ("failed", "The mission ended unexpectedly.")
        outcome, summary = run.finished
        for handle in self.registry.live(mission.id):
            await self.dispatcher.end_task(handle)
        if outcome != "succeeded":  # issue 39: what the gripper holds, read before it is told
            summary = await tell_what_is_held(
                self.tools, summary, self.config.tool_timeout_s, picked_last(mission.steps)
            )
            run.finished = (outcome, summary)
        for step in mission.steps:
            if step.status == "pending":
                step.set_status("skipped", "never run")
            elif step.status == "running":
                step.set_status(
                    "succeeded" if outcome == "succeeded" else "failed",
                    step.detail if outcome == "succeeded" else f"mission {outcome}",
                )
        mission.state = outcome
        mission.summary = summary
        mission.ended_at = mission.created_at.now(mission.created_at.tzinfo)
        await self.output.emit_plan(run)
        await self.emitter.emit(
            MissionFinished(
                mission_id=mission.id,
                outcome=outcome,
                summary=summary,
                usage=mission.usage.model_dump(),
            )
        )
        logger.info("mission_finished", outcome=outcome, summary=summary, steps=run.llm_steps)
        if summary:
            await self.speech.say(summary)

    async def recover(self) -> None:
        """At start-up: close the missions a crashed process life left live; the tasks they
        owned are cancelled when their servers connect (reconcile) and their late events
        acknowledged, never taken for live ones."""
        if self.archive is not None:
            owned = await close_interrupted(self.archive, self.trace, self.emitter, self.speech)
            self.dispatcher.interrupted |= owned

    async def wait_idle(self, timeout_s: float) -> None:
        """Wait for the running mission task (tests, shutdown)."""
        run = self.run
        if run is not None and run.task is not None:
            async with asyncio.timeout(timeout_s):
                await asyncio.shield(run.task)

    async def shutdown(self, timeout_s: float = 5.0) -> None:
        run = self.run
        if run is not None and run.task is not None:
            run.finished = run.finished or ("cancelled", "The app shut down.")
            run.task.cancel()
            await asyncio.wait({run.task}, timeout=timeout_s)
        self.dispatcher.shutdown()

    @property
    def skills(self) -> SkillLedger:
        """Vision skills started through the brain (mission or fast path) and still running."""
        return self.dispatcher.skills

    async def find_mission(self, mission_id: str) -> Mission | None:
        """A mission of this process life, else one from the archive (earlier lives)."""
        mission = self.store.get(mission_id)
        if mission is None and self.archive is not None:
            mission = await self.archive.load(mission_id)
        return mission

    async def recent_missions(self, limit: int) -> list[Mission]:
        live = self.store.recent(limit)
        ids = {m.id for m in live}
        archived = await self.archive.recent(limit) if self.archive is not None else []
        return (live + [m for m in archived if m.id not in ids])[:limit]

    def task_server(self, task_id: str) -> str | None:
        """The server that owns a live task (its events must come from there)."""
        handle = self.registry.get(task_id)
        return handle.server if handle is not None else None

    # --- delegates (dispatch.py / bargein.py) ---------------------------------------------
    async def execute(self, run: MissionRun, call: ToolCall) -> ToolResult:
        return await self.dispatcher.execute(run, call)

    async def on_task_event(self, event: TaskEvent) -> bool:
        return await self.dispatcher.on_task_event(event)

    async def cancel_task(self, server: str, task_id: str) -> None:
        await self.dispatcher.cancel_task(server, task_id)

    async def reconcile(self, server: str) -> None:
        await self.dispatcher.links.reconcile(server)
        await self.held_at_start.on_connect(server, idle=self.run is None)

    async def on_server_lost(self, server: str) -> None:
        await self.dispatcher.links.on_server_lost(server)

    def is_stop(self, text: str) -> bool:
        return self.bargein.is_stop(text)

    async def safety_stop(self, reason: str = "stop", by: str | None = None) -> str:
        """Latch the software stop and halt motion; what the person is told."""
        return await self.bargein.safety_stop(reason, by)
