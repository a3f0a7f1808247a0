"""The composition root: compose the Hydra tree, validate it, build every adapter, wire the app.

This is the only module that constructs adapters (``_target_`` per adapter YAML).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import socketio
import structlog
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate
from omegaconf import OmegaConf

from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.memory import MemoryClient
from robot_voice_chat.agent.mission import MissionStore
from robot_voice_chat.agent.teaching import Teaching
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.camera.base import CameraFeed
from robot_voice_chat.services.camera.http import HttpCameraFeed
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.emitter.history import ChatHistory, HistoryRecordingEmitter
from robot_voice_chat.services.emitter.socketio import SocketIOEventEmitter
from robot_voice_chat.services.llm.base import LLMProvider
from robot_voice_chat.services.speech.base import SpeechInput, SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import CONFIG_DIR, AppConfig, resolve_path

logger = structlog.get_logger(__name__)


class ConfigError(RuntimeError):
    """The composed configuration cannot run (bad values, missing required key)."""


def compose_config(deployment: str = "dev", overrides: list[str] | None = None) -> AppConfig:
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base=None):
        cfg = compose("config", overrides=[f"deployment={deployment}", *(overrides or [])])
    data = OmegaConf.to_container(cfg, resolve=True)
    assert isinstance(data, dict)
    return AppConfig.model_validate({**data, "deployment": deployment})


@dataclass
class Adapters:
    llm: LLMProvider
    planner: LLMProvider | None
    tools: ToolBackend
    speech_output: SpeechOutput
    speech_input: SpeechInput
    camera: CameraFeed | None = None


def build_adapters(config: AppConfig, emitter: EventEmitter) -> Adapters:
    try:
        llm = instantiate(config.llm)
    except Exception as exc:
        raise ConfigError(
            f"cannot build the fast-path LLM ({config.llm['_target_']}): {exc}"
        ) from exc
    planner = _build_planner(config)
    tools = McpToolBackend(
        config.tools.servers,
        blocking_tools=config.tools.blocking_tools,
        call_timeout_s=config.tools.call_timeout_s,
        connect_timeout_s=config.tools.connect_timeout_s,
        reconnect_interval_s=config.tools.reconnect_interval_s,
        health_interval_s=config.tools.health_interval_s,
    )
    return Adapters(
        llm=llm,
        planner=planner,
        tools=tools,
        speech_output=instantiate(config.speech_output, emitter=emitter),
        speech_input=instantiate(config.speech_input),
        camera=HttpCameraFeed(config.ui.camera_url, config.ui.camera_timeout_s),
    )


def _build_planner(config: AppConfig) -> LLMProvider | None:
    """Lazy and failure-tolerant (§7): without a key, missions are disabled, the app stays up."""
    if not config.agent.enabled or config.llm_planner is None:
        return None
    try:
        planner: LLMProvider = instantiate(config.llm_planner)
    except Exception as exc:
        logger.warning(
            "planner_disabled", target=config.llm_planner.get("_target_"), error=str(exc)
        )
        return None
    return planner


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
    history: ChatHistory = field(default_factory=ChatHistory)

    async def start(self) -> None:
        self.trace.prune(self.config.agent.trace_retention_days)
        self.adapters.tools.add_connect_listener(self.executor.reconcile)
        await self.adapters.tools.start()
        logger.info(
            "app_started",
            deployment=self.config.deployment,
            llm=self.adapters.llm.name,
            planner=self.adapters.planner.name if self.adapters.planner else None,
        )

    async def stop(self) -> None:
        await self.executor.shutdown()
        await self.adapters.tools.aclose()
        await self.adapters.speech_output.aclose()
        await self.adapters.llm.aclose()
        if self.adapters.camera is not None:
            await self.adapters.camera.aclose()
        if self.adapters.planner is not None:
            await self.adapters.planner.aclose()


def assemble(
    config: AppConfig, adapters: Adapters, emitter: EventEmitter, sio: Any = None
) -> Container:
    """Wire the application layer on top of already-built adapters (tests pass fakes here)."""
    history = ChatHistory(config.ui.chat_history_size)
    emitter = HistoryRecordingEmitter(emitter, history)
    trace = TraceRecorder(resolve_path(config.agent.trace_dir))
    memory = MemoryClient(adapters.tools, config.agent.memory_server, config.agent.tool_timeout_s)
    teaching = Teaching(emitter, memory)
    executor = MissionExecutor(
        planner=adapters.planner,
        tools=adapters.tools,
        emitter=emitter,
        speech=adapters.speech_output,
        memory=memory,
        trace=trace,
        teaching=teaching,
        config=config.agent,
        prompt_path=resolve_path(config.agent.prompt_file),
        store=MissionStore(),
    )
    pipeline = ChatPipeline(
        llm=adapters.llm,
        tools=adapters.tools,
        executor=executor,
        emitter=emitter,
        speech=adapters.speech_output,
        config=config.chat,
    )
    return Container(config, adapters, emitter, executor, pipeline, teaching, trace, sio, history)


def bootstrap(config: AppConfig) -> Container:
    sio = socketio.AsyncServer(
        async_mode="asgi", cors_allowed_origins=config.api.cors_origins or []
    )
    emitter = SocketIOEventEmitter(sio)
    return assemble(config, build_adapters(config, emitter), emitter, sio)
