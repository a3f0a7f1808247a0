"""Tool dispatch with step linkage (§5.3), task events + reactions (§5.4, §6), reconciliation."""

from __future__ import annotations

import json
import time
from typing import TYPE_CHECKING, Any

import structlog

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.plan_tools import LOCAL_TOOLS, strip_step_id
from robot_voice_chat.agent.reactions import Reaction
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.task_registry import (
    TaskHandle,
    format_event,
    parse_task_info,
    progress_detail,
    running_task_ids,
    server_restarted_event,
)
from robot_voice_chat.services.llm.base import ToolCall, ToolResult

if TYPE_CHECKING:
    from robot_voice_chat.agent.executor import MissionExecutor

logger = structlog.get_logger(__name__)
ORPHAN_GRACE_S = 30.0


def _short(args: dict[str, Any]) -> str:
    text = json.dumps(args, separators=(",", ":"), default=str)
    return text if len(text) <= 120 else text[:117] + "..."


async def execute(ex: MissionExecutor, run: MissionRun, call: ToolCall) -> ToolResult:
    if call.name in LOCAL_TOOLS:
        result = await ex.plan_tools.call(run, call)
        ex.trace.record(
            run.mission.id,
            "tool_result",
            tool=call.name,
            arguments=call.arguments,
            result=result.content[:2000],
            is_error=result.is_error,
        )
        return result
    step_id, args = strip_step_id(call.arguments)
    mission = run.mission
    step = mission.step(step_id)
    if mission.state == "paused" and not run.awaiting_user:
        mission.state = "running"
    if step is not None:
        step.set_status("running")
        await ex.emit_plan(run)
    await ex.log_line(run, "tool_call", f"{call.name}({_short(args)})")
    started = time.monotonic()
    outcome = await ex.tools.call_tool(call.name, args, ex.config.tool_timeout_s)
    duration_ms = round((time.monotonic() - started) * 1000, 1)
    ex.trace.record(
        mission.id,
        "tool_result",
        tool=call.name,
        arguments=args,
        step_id=step_id,
        result=outcome.text[:2000],
        is_error=outcome.is_error,
        duration_ms=duration_ms,
    )
    logger.info(
        "tool_dispatched", tool=call.name, is_error=outcome.is_error, duration_ms=duration_ms
    )
    info = None if outcome.is_error else parse_task_info(outcome.text)
    if info is not None:
        await _register_task(ex, run, call.name, step_id, info)
    elif step is not None:
        step.set_status("failed" if outcome.is_error else "succeeded", outcome.text[:160])
        await ex.emit_plan(run)
    return ToolResult(tool_call_id=call.id, content=outcome.text, is_error=outcome.is_error)


async def _register_task(
    ex: MissionExecutor,
    run: MissionRun,
    dotted: str,
    step_id: str | None,
    info: dict[str, Any],
) -> None:
    server, _, tool = dotted.partition(".")
    handle = TaskHandle(
        task_id=str(info["task_id"]),
        server=server,
        tool=tool,
        step_id=step_id,
        mission_id=run.mission.id,
    )
    ex.registry.register(handle)
    step = run.mission.step(step_id)
    if step is not None:
        step.task_id = handle.task_id
        eta = info.get("est_duration_s")
        step.detail = f"ETA {eta:.0f} s" if isinstance(eta, int | float) else "running"
        await ex.emit_plan(run)
    server_cfg = ex.tools.servers().get(server)
    if run.mission.state == "paused" and server_cfg is not None and server_cfg.motion:
        await cancel_task(ex, server, handle.task_id)  # a stop came in while it started
    now = time.monotonic()
    early = [
        e for t, e in ex.early_events if e.task_id == handle.task_id and now - t < ORPHAN_GRACE_S
    ]
    for event in sorted(early, key=lambda e: e.seq):
        await on_task_event(ex, event)


async def on_task_event(ex: MissionExecutor, event: TaskEvent) -> bool:
    """Reactions first, then step/UI updates and the planner inbox. False = orphan."""
    handle = ex.registry.get(event.task_id)
    run = ex.run
    if handle is None or run is None or handle.mission_id != run.mission.id:
        logger.info(
            "agent_event_orphan", task_id=event.task_id, server=event.server, type=event.type
        )
        ex.early_events.append((time.monotonic(), event))
        return False
    for reaction in run.reactions.take(event):
        await _react(ex, run, reaction, event)
    ex.registry.resolve(event)
    text = format_event(event, handle.label)
    ex.trace.record(
        run.mission.id,
        "task_event",
        type=event.type,
        task_id=event.task_id,
        text=text,
        payload=event.payload,
    )
    step = run.mission.step(handle.step_id)
    if step is not None:
        if event.type == "progress":
            step.detail = progress_detail(event.payload)
        elif event.type == "task_done":
            step.set_status("succeeded", "done")
        elif event.type == "task_failed":
            step.set_status(
                "failed",
                f"{event.payload.get('error_code', 'FAILED')}: {event.payload.get('message', '')}",
            )
        await ex.emit_plan(run)
    if text is not None:
        await ex.log_line(run, "task_event", text)
        run.post(text)
    return True


async def _react(
    ex: MissionExecutor, run: MissionRun, reaction: Reaction, event: TaskEvent
) -> None:
    call = reaction.call
    trigger = event.payload.get("trigger")
    name = trigger.get("type", event.type) if isinstance(trigger, dict) else (trigger or event.type)
    note = f"[reaction] {name} fired → called {call.tool}({_short(call.arguments)})"
    ex.spawn(_fire(ex, run.mission.id, call.tool, call.arguments))
    run.inbox.append(note)
    await ex.log_line(run, "reaction", note)
    ex.trace.record(run.mission.id, "reaction", text=note)


async def _fire(ex: MissionExecutor, mission_id: str, tool: str, arguments: dict[str, Any]) -> None:
    outcome = await ex.tools.call_tool(tool, arguments, ex.config.tool_timeout_s)
    ex.trace.record(
        mission_id,
        "tool_result",
        tool=tool,
        arguments=arguments,
        result=outcome.text[:500],
        is_error=outcome.is_error,
        reaction=True,
    )
    logger.info("reaction_dispatched", tool=tool, is_error=outcome.is_error)


async def cancel_task(ex: MissionExecutor, server: str, task_id: str) -> None:
    outcome = await ex.tools.call_tool(
        f"{server}.cancel_task", {"task_id": task_id}, ex.config.tool_timeout_s
    )
    logger.info("task_cancel_requested", server=server, task_id=task_id, is_error=outcome.is_error)


async def reconcile(ex: MissionExecutor, server: str) -> None:
    """Hook for (re)connects: lost tasks → SERVER_RESTARTED; orphans cancelled when idle."""
    if not ex.tools.has_tool(f"{server}.list_tasks"):
        return
    outcome = await ex.tools.call_tool(
        f"{server}.list_tasks", {"states": ["running"]}, ex.config.tool_timeout_s
    )
    running = None if outcome.is_error else running_task_ids(outcome.text)
    if running is None:
        logger.warning("reconcile_failed", server=server, result=outcome.text[:200])
        return
    for handle in ex.registry.live(server=server):
        if handle.task_id not in running:
            logger.warning("task_lost_on_restart", server=server, task_id=handle.task_id)
            await on_task_event(ex, server_restarted_event(handle))
    if ex.run is None:
        for task_id in sorted(running):
            if ex.registry.get(task_id) is None:
                logger.warning("orphan_task_cancelled", server=server, task_id=task_id)
                await cancel_task(ex, server, task_id)
