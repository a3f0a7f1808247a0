"""The brain's links to its servers: a server lost with the mission's tasks on it, a motion
call cut off by its server's death, a reconnect reconciled (lost tasks → SERVER_RESTARTED,
orphans cancelled), and motion nobody here started stopped while the software stop is latched.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any, Protocol

import structlog

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.output import MissionOutput
from robot_voice_chat.agent.recovery import stopped_after_restart
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.supervision_words import lost_motion_server, stop_hint
from robot_voice_chat.agent.task_registry import (
    TaskRegistry,
    running_task_ids,
    server_restarted_event,
)
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import service_name
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.settings import AgentConfig

logger = structlog.get_logger(__name__)
MOVING_EVENTS = frozenset({"progress", "trigger_fired"})  # the motion still runs


class LinksHost(Protocol):
    """What the server links use of the dispatcher."""

    tools: ToolBackend
    registry: TaskRegistry
    trace: TraceRecorder
    config: AgentConfig
    output: MissionOutput
    supervisor: MotionSupervisor | None
    interrupted: set[str]
    current_run: Callable[[], MissionRun | None]
    latched: Callable[[], bool]

    def spawn(self, coro: Coroutine[Any, Any, None]) -> None: ...

    async def cancel_task(self, server: str, task_id: str) -> None: ...

    async def on_task_event(self, event: TaskEvent) -> bool: ...

    def is_motion(self, server: str) -> bool: ...


class ServerLinks:
    """Server losses, reconnects and orphan motion, for one dispatcher."""

    def __init__(self, host: LinksHost) -> None:
        self.host = host
        self.lost_servers: set[str] = set()  # servers the running mission was told are gone
        self.stopped_orphans: set[tuple[str, str]] = set()  # (server, task) stopped while latched

    def stop_orphan_if_latched(self, event: TaskEvent) -> None:
        """Motion the brain did not start, reported while the software stop is latched: stop
        it (its cancel_task and the server's stop tool), whoever started it (issue 27)."""
        cfg = self.host.tools.servers().get(event.server)
        key = (event.server, event.task_id)
        if (
            cfg is None
            or not cfg.motion
            or event.type not in MOVING_EVENTS
            or not self.host.latched()
            or key in self.stopped_orphans
        ):
            return
        self.stopped_orphans.add(key)
        logger.warning("orphan_motion_stopped", server=event.server, task_id=event.task_id)
        self.host.spawn(self.host.cancel_task(event.server, event.task_id))
        if cfg.safety_stop_tool:
            self.host.spawn(self._stop_tool(f"{event.server}.{cfg.safety_stop_tool}"))

    async def _stop_tool(self, tool: str) -> None:
        outcome = await self.host.tools.call_tool(tool, {}, self.host.config.tool_timeout_s)
        logger.info("safety_stop_tool_called", tool=tool, is_error=outcome.is_error)

    async def on_server_lost(self, server: str) -> None:
        """A server the running mission has live tasks on went away (issue 23 item 4): the
        steps show it, the person is told and the planner woken. Bound: the backend notices
        within ``tools.health_interval_s`` + ``tools.connect_timeout_s`` of the loss."""
        run = self.host.current_run()
        if run is None:
            return
        handles = self.host.registry.live(run.mission.id, server=server)
        if not handles:
            return
        self.lost_servers.add(server)
        ids = ", ".join(h.task_id for h in handles)
        logger.warning("mission_server_lost", server=server, tasks=ids)
        for handle in handles:
            step = run.mission.step(handle.step_id)
            if step is not None and step.status == "running":
                step.detail = f"{server} server unreachable: waiting for it to come back"
        await self.host.output.emit_plan(run)
        line = (
            f"[server {server}] unreachable: tasks {ids} cannot report until it is back "
            "(if it restarted, its lost tasks come back as SERVER_RESTARTED)"
        )
        self.host.trace.record(run.mission.id, "server_lost", server=server, tasks=ids, text=line)
        await self.host.output.log_line(run, "task_event", line)
        cfg = self.host.tools.servers().get(server)
        if cfg is not None and cfg.motion:  # said only once the lease surely ran out
            said = await lost_motion_server(self.host.supervisor, server)
        else:
            said = (
                f"I lost contact with my {service_name(server)} and am waiting for it to come "
                f"back.{stop_hint(self.host.supervisor)}"
            )
        await self.host.output.say(run, said)
        run.post(line)

    async def cut_off(self, run: MissionRun, server: str) -> None:
        """A motion call whose server went away while it was out: told at once, like a server
        lost with a running task (the lease decides whether it holds itself stopped)."""
        if server in self.lost_servers:
            return
        self.lost_servers.add(server)
        logger.warning("motion_call_cut_off", server=server)
        await self.host.output.say(run, await lost_motion_server(self.host.supervisor, server))

    async def reconcile(self, server: str) -> None:
        """Hook for (re)connects: lost tasks → SERVER_RESTARTED; orphans cancelled when idle."""
        run = self.host.current_run()
        if server in self.lost_servers and run is not None:
            self.lost_servers.discard(server)
            line = f"[server {server}] back: reconnected"
            await self.host.output.log_line(run, "task_event", line)
            run.post(line)
        if not self.host.tools.has_tool(f"{server}.list_tasks"):
            return
        with dispatching(DispatchContext(may_ask=False, caller="the brain's reconciliation")):
            outcome = await self.host.tools.call_tool(
                f"{server}.list_tasks", {"states": ["running"]}, self.host.config.tool_timeout_s
            )
        running = None if outcome.is_error else running_task_ids(outcome.text)
        if running is None:
            logger.warning("reconcile_failed", server=server, result=outcome.text[:200])
            return
        for handle in self.host.registry.live(server=server):
            if handle.task_id not in running:
                logger.warning("task_lost_on_restart", server=server, task_id=handle.task_id)
                await self.host.on_task_event(server_restarted_event(handle))
        idle = self.host.current_run() is None
        for task_id in sorted(running):
            # an interrupted mission's task is cancelled even while a new mission runs
            if self.host.registry.get(task_id) is None and (
                idle or task_id in self.host.interrupted
            ):
                logger.warning(
                    "orphan_task_cancelled",
                    server=server,
                    task_id=task_id,
                    interrupted=task_id in self.host.interrupted,
                )
                await self.host.cancel_task(server, task_id)
                if task_id in self.host.interrupted and self.host.is_motion(server):
                    await self.host.output.speech.say(stopped_after_restart(server))
