"""Barge-in (spec §9): halt motion first — no LLM in the path — then pause and ask."""

from __future__ import annotations

import asyncio
import re
from typing import TYPE_CHECKING

import structlog

if TYPE_CHECKING:
    from robot_voice_chat.agent.executor import MissionExecutor

logger = structlog.get_logger(__name__)
STOP_QUESTION = "Stopped. Should I continue or abort?"


def is_stop(ex: MissionExecutor, text: str) -> bool:
    words = re.findall(r"[^\W\d_]+", text.lower())
    return any(word in ex.config.stop_words for word in words[:6])


async def safety_stop(ex: MissionExecutor, reason: str = "stop") -> None:
    """(1) cancel motion tasks + safety_stop_tool, (2) interrupt speech, (3) pause,
    (4) ask, (5) suspend until the user answers."""
    run = ex.run
    calls = []
    cancelled = []
    for server in ex.tools.servers().values():
        if not server.motion:
            continue
        for handle in ex.registry.live(server=server.name):
            cancelled.append(ex.registry.drop(handle.task_id) or handle)
            calls.append(ex.cancel_task(server.name, handle.task_id))
        if server.safety_stop_tool:
            calls.append(_safety_tool(ex, f"{server.name}.{server.safety_stop_tool}"))
    await asyncio.gather(*calls)
    await ex.speech.interrupt()
    logger.warning("safety_stop", reason=reason, cancelled=[h.task_id for h in cancelled])
    if run is None or not run.mission.active:
        return
    if run.llm_call is not None:
        run.llm_call.cancel()
    run.mission.state = "paused"
    for handle in cancelled:
        step = run.mission.step(handle.step_id)
        if step is not None:
            step.set_status("failed", "safety stop")
    ex.trace.record(
        run.mission.id, "safety_stop", reason=reason, cancelled=[h.task_id for h in cancelled]
    )
    await ex.emit_plan(run)
    await ex.say(run, STOP_QUESTION)
    run.suspended = True
    run.awaiting_user = True


async def _safety_tool(ex: MissionExecutor, tool: str) -> None:
    outcome = await ex.tools.call_tool(tool, {}, ex.config.tool_timeout_s)
    logger.info("safety_stop_tool_called", tool=tool, is_error=outcome.is_error)
