"""The assembled brain the HTTP and Socket.IO layer serves: its adapters at every port and the
application objects wired on top of them. ``composition.py`` builds it; the routes read it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import structlog

from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.teaching import Teaching
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.api.auth import OperatorAuth
from robot_voice_chat.api.seen_events import SeenEvents
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.camera.base import CameraFeed
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.emitter.history import ChatHistory
from robot_voice_chat.services.llm.base import LLMProvider
from robot_voice_chat.services.speech.base import SpeechInput, SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.settings import AppConfig

# the start line keeps the logger it was always written by
logger = structlog.get_logger("robot_voice_chat.composition")


@dataclass
class Adapters:
    llm: LLMProvider
    planner: LLMProvider | None
    tools: ToolBackend
    speech_output: SpeechOutput
    speech_input: SpeechInput
    camera: CameraFeed | None = None


@dataclass
class Container:
    config: AppConfig
    adapters: Adapters
    emitter: EventEmitter
    executor: MissionExecutor
    pipeline: ChatPipeline
    teaching: Teaching
    trace: TraceRecorder
    sio: Any = None
    auth: OperatorAuth | None = None  # None: no operator login (dev on loopback)
    history: ChatHistory = field(default_factory=ChatHistory)
    supervisor: MotionSupervisor | None = None  # the lease on every motion server
    seen_events: SeenEvents | None = None  # handled event ids across restarts (the ingress)

    def policy_summary(self) -> dict[str, Any] | None:
        """The tool policy in force (version, digest, file) for readyz."""
        tools = self.adapters.tools
        policy = tools.policy if isinstance(tools, GuardedToolBackend) else None
        return policy.summary() if policy is not None else None

    async def start(self) -> None:
        self.trace.prune(self.config.agent.trace_retention_days)
        await self.executor.recover()  # before any server connects and reconciles
        self.adapters.tools.add_connect_listener(self.executor.reconcile)
        self.adapters.tools.add_disconnect_listener(self.executor.on_server_lost)
        await self.adapters.tools.start()
        if self.supervisor is not None:
            await self.supervisor.start()
        logger.info(
            "app_started",
            deployment=self.config.deployment,
            llm=self.adapters.llm.name,
            planner=self.adapters.planner.name if self.adapters.planner else None,
        )

    async def stop(self) -> None:
        await self.executor.shutdown()
        if self.supervisor is not None:
            await self.supervisor.aclose()
        await self.adapters.tools.aclose()
        await self.adapters.speech_output.aclose()
        await self.adapters.llm.aclose()
        if self.adapters.camera is not None:
            await self.adapters.camera.aclose()
        if self.adapters.planner is not None:
            await self.adapters.planner.aclose()
