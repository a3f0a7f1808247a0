"""The composition root: compose the Hydra tree, validate it, build every adapter, wire the app.

This is the only module that constructs adapters (``_target_`` per adapter YAML).
"""

from __future__ import annotations

import importlib
import inspect
import uuid
from collections.abc import Awaitable, Callable
from dataclasses import replace
from typing import Any

import socketio
import structlog
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.errors import HydraException
from hydra.utils import instantiate
from omegaconf import OmegaConf
from omegaconf.errors import OmegaConfBaseException
from pydantic import ValidationError

from robot_mcp_kit.supervision import SUPERVISE_TOOL
from robot_voice_chat.agent.archive import MissionArchive, SqliteMissionArchive
from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.memory import MemoryClient
from robot_voice_chat.agent.mission import MissionStore
from robot_voice_chat.agent.teaching import Teaching
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.api.auth import AdminSecrets, AuthSetupError, OperatorAuth
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.api.seen_events import SqliteSeenEvents
from robot_voice_chat.control.alarms import BY_SUPERVISION, AlarmAnnouncer
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.elicitation import approval_elicitation
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import FileLatchStore, LatchState
from robot_voice_chat.control.lease_link import LeaseProcess
from robot_voice_chat.control.policy import PolicyError, ToolPolicy
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.camera.http import HttpCameraFeed
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.emitter.episodic import EpisodicNoteEmitter
from robot_voice_chat.services.emitter.history import ChatHistory, HistoryRecordingEmitter
from robot_voice_chat.services.emitter.socketio import SocketIOEventEmitter
from robot_voice_chat.services.llm.base import LLMProvider
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import (
    CONFIG_DIR,
    AgentConfig,
    AppConfig,
    data_dir,
    resolve_path,
    state_path,
)
from robot_voice_chat.socket_events import ChatMessage, SafetyState
from robot_voice_chat.socket_origins import origin_policy

logger = structlog.get_logger(__name__)
LEASE_RECONNECT_S = 1.0  # the lease's own connection retries a lost motion server this often


class ConfigError(RuntimeError):
    """The composed configuration cannot run (bad values, missing required key)."""


def one_line(text: str) -> str:
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def compose_config(deployment: str = "dev", overrides: list[str] | None = None) -> AppConfig:
    """Compose + validate; any bad preset, override or value is one :class:`ConfigError`."""
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base=None):
            cfg = compose("config", overrides=[f"deployment={deployment}", *(overrides or [])])
        data = OmegaConf.to_container(cfg, resolve=True)
        assert isinstance(data, dict)
        return AppConfig.model_validate({**data, "deployment": deployment})
    except ValidationError as exc:
        raise ConfigError(f"configuration ({deployment}): {validation_summary(exc)}") from exc
    except (HydraException, OmegaConfBaseException) as exc:
        raise ConfigError(f"configuration ({deployment}): {one_line(str(exc))}") from exc


def validation_summary(exc: ValidationError) -> str:
    """``where: what`` for each error — never the input value (it may be a secret)."""
    return "; ".join(
        f"{'.'.join(map(str, e['loc'])) or exc.title}: {one_line(e['msg'])}"
        for e in exc.errors(include_url=False, include_input=False, include_context=False)
    )


def _reason(exc: BaseException) -> str:
    """The one line a person needs: the missing package, or the adapter's own message."""
    chain: list[BaseException] = []
    current: BaseException | None = exc
    while current is not None and current not in chain:
        chain.append(current)
        current = current.__cause__ or current.__context__
    missing = next((e for e in chain if isinstance(e, ModuleNotFoundError) and e.name), None)
    if isinstance(missing, ModuleNotFoundError):
        return (
            f"the Python package {missing.name!r} is not installed; install it "
            "(uv sync --all-packages --inexact, or pip install it into this environment)"
        )
    own = next((e for e in chain if isinstance(e, ValueError | ImportError)), exc)
    return one_line(str(own))


def build_adapter(group: str, cfg: dict[str, Any], **wiring: Any) -> Any:
    """Instantiate one adapter; ``wiring`` goes only to adapters that take it (e.g. the
    emitter for browser speech). Failure = one :class:`ConfigError` line, never a traceback."""
    target = str(cfg.get("_target_"))
    try:
        module, _, name = target.rpartition(".")
        accepted = inspect.signature(getattr(importlib.import_module(module), name)).parameters
        return instantiate(cfg, **{k: v for k, v in wiring.items() if k in accepted})
    except Exception as exc:
        raise ConfigError(f"cannot build {group} ({target}): {_reason(exc)}") from exc


def build_adapters(config: AppConfig, emitter: EventEmitter) -> Adapters:
    llm = build_adapter("llm", config.llm)
    planner = _build_planner(config)
    tools = McpToolBackend(
        config.tools.servers,
        blocking_tools=config.tools.blocking_tools,
        call_timeout_s=config.tools.call_timeout_s,
        connect_timeout_s=config.tools.connect_timeout_s,
        reconnect_interval_s=config.tools.reconnect_interval_s,
        health_interval_s=config.tools.health_interval_s,
        quiet_tools=frozenset({SUPERVISE_TOOL}),
    )
    return Adapters(
        llm=llm,
        planner=planner,
        tools=tools,
        speech_output=build_adapter("speech_output", config.speech_output, emitter=emitter),
        speech_input=build_adapter("speech_input", config.speech_input),
        camera=HttpCameraFeed(
            config.ui.camera_url,
            config.ui.camera_timeout_s,
            config.ui.camera_max_bytes,
            token=config.ui.camera_token,
        ),
    )


def _build_planner(config: AppConfig) -> LLMProvider | None:
    """A configured planner must build: a missing key or package refuses the start (exit 2).
    Deployments without keys select the rules planner (ARCHITECTURE §6); ``agent.enabled:
    false`` runs chat only."""
    if not config.agent.enabled or config.llm_planner is None:
        return None
    planner: LLMProvider = build_adapter("llm_planner", config.llm_planner)
    return planner


def assemble(
    config: AppConfig, adapters: Adapters, emitter: EventEmitter, sio: Any = None
) -> Container:
    """Wire the application layer on top of already-built adapters (tests pass fakes here)."""
    history = ChatHistory(config.ui.chat_history_size)
    emitter = HistoryRecordingEmitter(emitter, history)
    emitter = EpisodicNoteEmitter(emitter, adapters.tools)
    agent = config.agent
    latch = SafetyLatch(FileLatchStore(data_dir(agent) / "safety"))
    policy = load_policy(config)
    trace = TraceRecorder(state_path(agent, agent.trace_dir, "missions"))
    approvals = ApprovalBroker(
        emitter=emitter,
        trace=trace,
        audit_path=state_path(agent, config.control.audit_log, "approvals.jsonl"),
        timeout_s=config.control.approval_timeout_s,
    )
    # the lease is the brain's own control traffic: the supervisor alone holds the raw backend
    # in a process (or on a thread) of its own with its own connections (issue 39): a busy loop
    # cannot starve it
    thread_runner = config.control.lease_runner == "thread"
    supervisor = MotionSupervisor(
        adapters.tools,
        latch,
        period_s=config.control.lease_period_s,
        ttl_s=config.control.lease_ttl_s,
        lease_tools=_lease_tools(config, adapters.tools) if thread_runner else None,
        hung_after_s=config.control.lease_hung_s,
        lease_process=None if thread_runner else _lease_process(config, adapters.tools),
    )
    latch.add_listener(_announce_latch(emitter, supervisor))
    # the one choke point: everything below holds the guarded backend, never the raw one
    guarded = GuardedToolBackend(adapters.tools, latch, policy, approvals, supervisor)
    adapters = replace(adapters, tools=guarded)
    archive = SqliteMissionArchive(state_path(agent, agent.missions_db, "missions.sqlite3"))
    executor = build_executor(
        config.agent,
        adapters.planner,
        adapters.tools,
        emitter,
        adapters.speech_output,
        trace,
        store=MissionStore(),
        archive=archive,
        latch=latch,
        approvals=approvals,
        supervisor=supervisor,
    )
    guarded.set_elicitation_handler(
        approval_elicitation(
            approvals,
            lambda: executor.active.id if executor.active else None,
            min(agent.tool_timeout_s, config.tools.call_timeout_s),
        )
    )
    supervisor.set_notice_handler(
        AlarmAnnouncer(
            stop=lambda reason: executor.safety_stop(reason, by=BY_SUPERVISION),
            tell=_tell(emitter, adapters.speech_output),
        )
    )
    pipeline = ChatPipeline(
        llm=adapters.llm,
        tools=adapters.tools,
        executor=executor,
        emitter=emitter,
        speech=adapters.speech_output,
        config=config.chat,
    )
    seen = SqliteSeenEvents(state_path(agent, "", "seen_events.sqlite3"), config.api.dedupe_size)
    return Container(
        config,
        adapters,
        emitter,
        executor,
        pipeline,
        executor.teaching,
        trace,
        sio,
        history=history,
        supervisor=supervisor,
        seen_events=seen,
    )


def build_executor(
    config: AgentConfig,
    planner: LLMProvider | None,
    tools: ToolBackend,
    emitter: EventEmitter,
    speech: SpeechOutput,
    trace: TraceRecorder,
    *,
    memory: MemoryClient | None = None,
    store: MissionStore | None = None,
    archive: MissionArchive | None = None,
    latch: SafetyLatch | None = None,
    approvals: ApprovalBroker | None = None,
    supervisor: MotionSupervisor | None = None,
) -> MissionExecutor:
    """The mission executor with its memory client and teaching: built here and nowhere else
    (``assemble`` for the product; test harnesses pass their fakes). ``memory`` default: a
    client of the configured memory server on ``tools``."""
    memory = memory or MemoryClient(tools, config.memory_server, config.tool_timeout_s)
    return MissionExecutor(
        planner=planner,
        tools=tools,
        emitter=emitter,
        speech=speech,
        memory=memory,
        trace=trace,
        teaching=Teaching(emitter, memory),
        config=config,
        prompt_path=resolve_path(config.prompt_file),
        store=store,
        archive=archive,
        latch=latch,
        approvals=approvals,
        supervisor=supervisor,
    )


def load_policy(config: AppConfig) -> ToolPolicy:
    path = resolve_path(config.control.policy_file)
    try:
        policy = ToolPolicy.load(path)
    except PolicyError as exc:
        raise ConfigError(str(exc)) from exc
    logger.info("policy_loaded", **policy.summary())
    return policy


def _announce_latch(emitter: EventEmitter, supervisor: MotionSupervisor) -> Any:
    async def announce(state: LatchState) -> None:
        await emitter.emit(SafetyState(**state.model_dump(), alarms=supervisor.alarms()))

    return announce


def _lease_backend(config: AppConfig) -> dict[str, Any]:
    """The lease connections' settings (``McpToolBackend`` keywords)."""
    return {
        "call_timeout_s": config.control.lease_ttl_s,
        "connect_timeout_s": config.tools.connect_timeout_s,
        "reconnect_interval_s": min(config.tools.reconnect_interval_s, LEASE_RECONNECT_S),
        "health_interval_s": config.tools.health_interval_s,
        "quiet_tools": frozenset({SUPERVISE_TOOL}),
    }


def _lease_tools(config: AppConfig, tools: ToolBackend) -> Callable[[], ToolBackend] | None:
    """The lease's own MCP connections to the motion servers (same URLs, transports and
    credential as the brain's), built on the supervisor's thread; None for in-process fakes."""
    if not isinstance(tools, McpToolBackend):
        return None
    motion = [cfg for cfg in tools.servers().values() if cfg.motion]

    def build() -> ToolBackend:
        return McpToolBackend(motion, **_lease_backend(config))

    return build


def _lease_process(config: AppConfig, tools: ToolBackend) -> LeaseProcess | None:
    """The lease in a child process with its own connections (same URLs, transports and
    credential, handed over its stdin); None for in-process fakes."""
    if not isinstance(tools, McpToolBackend):
        return None
    motion = [cfg for cfg in tools.servers().values() if cfg.motion]
    return LeaseProcess(motion, _lease_backend(config))


def _tell(emitter: EventEmitter, speech: SpeechOutput) -> Callable[[str], Awaitable[None]]:
    """Said and shown as the robot's words, outside any mission's own lines."""

    async def tell(text: str) -> None:
        await emitter.emit(ChatMessage(turn_id=uuid.uuid4().hex[:8], role="assistant", text=text))
        await speech.say(text)

    return tell


def bootstrap(config: AppConfig) -> Container:
    auth = build_auth(config)  # first: a refused login setup is the only line printed
    sio = socketio.AsyncServer(
        async_mode="asgi", cors_allowed_origins=origin_policy(config.api.cors_origins)
    )
    emitter = SocketIOEventEmitter(sio)
    container = assemble(config, build_adapters(config, emitter), emitter, sio)
    container.auth = auth
    return container


def build_auth(config: AppConfig) -> OperatorAuth | None:
    if not config.auth.enabled:
        configured = AdminSecrets().password_hash
        if configured is not None and configured.get_secret_value().strip():
            # Someone meant to protect this brain: refuse rather than serve it without login.
            raise ConfigError(
                f"ADMIN_PASSWORD_HASH is set but operator login is off in the "
                f"{config.deployment} preset: set auth.enabled=true (or RVC_DEPLOYMENT=robot) "
                "to require login, or unset ADMIN_PASSWORD_HASH"
            )
        return None
    try:
        return OperatorAuth.from_env(
            config.auth, revocations=state_path(config.agent, "", "revoked_sessions.json")
        )
    except AuthSetupError as exc:
        raise ConfigError(str(exc)) from exc
