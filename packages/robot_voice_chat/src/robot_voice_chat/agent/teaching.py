"""Teaching (spec §8): one-shot flag, trace → transcript → distillation → memory.save_process."""

from __future__ import annotations

import json
from typing import Any

import structlog

from robot_voice_chat.agent.memory import MemoryClient
from robot_voice_chat.agent.prompt import AgentPrompt
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.control.latch import NO_LOGIN, acting
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.llm.base import LLMError, LLMProvider, Message
from robot_voice_chat.socket_events import TeachingFailed, TeachingSaved, TeachingState

logger = structlog.get_logger(__name__)

_SKIP = {"progress"}


def render_transcript(trace: list[dict[str, Any]]) -> str:
    """Compact text of what happened: calls + args + result snippets, failures, corrections."""
    lines: list[str] = []
    for rec in trace:
        kind = rec.get("kind")
        if kind == "instruction":
            lines.append(f"INSTRUCTION: {rec.get('instruction')}")
        elif kind == "tool_result":
            status = "ERROR" if rec.get("is_error") else "ok"
            args = json.dumps(rec.get("arguments", {}), separators=(",", ":"))
            lines.append(
                f"CALL {rec.get('tool')}({args}) -> {status}: {str(rec.get('result', ''))[:160]}"
            )
        elif kind == "task_event" and rec.get("type") not in _SKIP:
            lines.append(f"EVENT {rec.get('text') or rec.get('type')}")
        elif kind == "user_turn":
            lines.append(f"USER: {rec.get('text')}")
        elif kind == "reaction":
            lines.append(f"REACTION {rec.get('text')}")
        elif kind == "final":
            lines.append(f"OUTCOME {rec.get('outcome')}: {rec.get('summary')}")
    return "\n".join(lines)


class Teaching:
    def __init__(self, emitter: EventEmitter, memory: MemoryClient) -> None:
        self._emitter = emitter
        self._memory = memory
        self.armed = False
        self.armed_by = NO_LOGIN  # who pressed Teach: their yes to storing what it teaches

    async def arm(self, enabled: bool) -> None:
        self.armed = enabled
        if enabled:
            self.armed_by = acting()
        await self._emitter.emit(TeachingState(armed=enabled))

    async def take(self) -> bool:
        """Consume the one-shot flag for a starting mission."""
        armed, self.armed = self.armed, False
        if armed:
            await self._emitter.emit(TeachingState(armed=False))
        return armed

    async def distill_and_save(
        self, planner: LLMProvider, prompt: AgentPrompt, trace: list[dict[str, Any]]
    ) -> str | None:
        """Never raises: failures are logged and emitted as ``teaching_failed``."""
        transcript = render_transcript(trace)
        try:
            response = await planner.chat(
                [
                    Message(role="system", content=prompt.distillation),
                    Message(role="user", content=f"Mission transcript:\n{transcript}"),
                ]
            )
            markdown = response.text.strip()
            if not markdown.startswith("---"):
                raise ValueError("distillation did not return a process document")
            # the operator who armed teaching approved this save (policy: confirm)
            with dispatching(DispatchContext(approved_by=f"teaching armed by {self.armed_by}")):
                process_id = await self._memory.save_process(markdown)
        except (LLMError, ValueError, RuntimeError) as exc:
            logger.warning("teaching_failed", reason=str(exc)[:300])
            await self._emitter.emit(TeachingFailed(reason=str(exc)[:300]))
            return None
        logger.info("teaching_saved", process_id=process_id)
        await self._emitter.emit(TeachingSaved(process_id=process_id))
        return process_id
