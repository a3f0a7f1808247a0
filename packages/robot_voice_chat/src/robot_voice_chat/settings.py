"""Validated configuration (Pydantic) for the composed Hydra tree and the environment."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Literal

import platformdirs
from limits import parse
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SecretStr,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_settings import BaseSettings, SettingsConfigDict

PACKAGE_DIR = Path(__file__).resolve().parent
CONFIG_DIR = PACKAGE_DIR / "config"
Transport = Literal["stdio", "sse", "streamable_http"]
MIN_EVENT_SECRET_BYTES = 32
MIN_CREDENTIAL_BYTES = 32  # what the servers accept (robot_mcp_kit.service_auth)


class EnvSettings(BaseSettings):
    """Process environment: which deployment preset to compose, log format."""

    model_config = SettingsConfigDict(env_prefix="RVC_", extra="ignore")

    deployment: str = "dev"
    log_format: str = "json"
    log_level: str = "INFO"
    config_overrides: str = ""  # RVC_CONFIG_OVERRIDES: space-separated Hydra overrides


class AgentConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    enabled: bool = True
    max_llm_steps: int = Field(40, ge=1)
    max_wall_clock_s: float = Field(1800, gt=0)
    max_cost_usd: float | None = None
    wakeup_timeout_s: float = Field(60, gt=0)
    trace_retention_days: int = Field(30, ge=0)
    trace_dir: str = ""  # "" = <data_dir>/missions
    # The brain's state directory: RVC_DATA_DIR, else the per-user data dir (platformdirs).
    data_dir: str = Field(default_factory=lambda: os.environ.get("RVC_DATA_DIR", ""))
    missions_db: str = ""  # "" = <data_dir>/missions.sqlite3
    stop_words: list[str] = Field(default_factory=lambda: ["stop", "halt", "stopp"])
    prompt_file: str = "config/agent_prompt.yaml"
    memory_server: str = "memory"
    processes_k: int = 3
    tool_timeout_s: float = 30.0

    @field_validator("stop_words")
    @classmethod
    def _lower(cls, words: list[str]) -> list[str]:
        return [w.strip().lower() for w in words if w.strip()]


class McpServerConfig(BaseModel):
    """One entry of ``config/tools/mcp.yaml``."""

    name: str = Field(pattern=r"^[A-Za-z0-9_\-]+$")
    transport: Transport = "sse"
    url: str | None = None
    command: str | None = None
    args: list[str] = Field(default_factory=list)
    env: dict[str, str] = Field(default_factory=dict)
    event_secret: SecretStr | None = None
    auth_token: SecretStr | None = None
    """This server's credential (its ``MCP_AUTH_TOKEN``), sent as ``Authorization: Bearer``
    on every HTTP request; empty = none (stdio needs none)."""
    approval_secret: SecretStr | None = None
    """The secret this server checks approvals with (its ``MCP_APPROVAL_SECRET``): the brain
    signs the approval of every call an operator approved with it (``robot_mcp_kit.approvals``);
    empty = the brain sends none and a server that demands one refuses the call."""
    motion: bool = False
    safety_stop_tool: str | None = None
    read_tools: list[str] = Field(default_factory=list)
    """A motion server's tools that only read: with the task contract's ``get_task`` /
    ``list_tasks`` and its stop tools, the only ones that pass while the software stop is
    latched. The brain's own list: what the server's annotations claim never counts
    (issue 27 item 4)."""
    optional: bool = False
    """A server the stack may run without (e.g. ``episodic``): readiness does not wait for it;
    its tools are offered while it is connected."""

    @field_validator("auth_token", "approval_secret")
    @classmethod
    def _usable_credential(cls, token: SecretStr | None, info: ValidationInfo) -> SecretStr | None:
        """Empty = none; anything else must be >= 32 bytes (the servers refuse less)."""
        value = token.get_secret_value().strip() if token is not None else ""
        if not value:
            return None
        if len(value.encode()) < MIN_CREDENTIAL_BYTES:
            variable = (
                "MCP_AUTH_TOKEN" if info.field_name == "auth_token" else "MCP_APPROVAL_SECRET"
            )
            raise ValueError(
                f"{info.field_name} is {len(value.encode())} bytes; the server's {variable} "
                f"has at least {MIN_CREDENTIAL_BYTES}"
            )
        return SecretStr(value)

    @property
    def needs_credential(self) -> bool:
        return self.transport != "stdio"

    @field_validator("event_secret")
    @classmethod
    def _strong_secret(cls, secret: SecretStr | None) -> SecretStr | None:
        """Empty = this server cannot post events; anything else must be >= 32 bytes."""
        value = secret.get_secret_value() if secret is not None else ""
        if value and len(value.encode()) < MIN_EVENT_SECRET_BYTES:
            raise ValueError(
                f"event_secret is {len(value.encode())} bytes; at least "
                f"{MIN_EVENT_SECRET_BYTES} are required (python3 -c "
                '"import secrets; print(secrets.token_hex(32))")'
            )
        return secret

    @property
    def can_post_events(self) -> bool:
        return self.event_secret is not None and bool(self.event_secret.get_secret_value())


class McpToolsConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    servers: list[McpServerConfig] = Field(default_factory=list)
    blocking_tools: list[str] = Field(default_factory=list)
    call_timeout_s: float = Field(30.0, gt=0)
    connect_timeout_s: float = Field(10.0, gt=0)
    reconnect_interval_s: float = Field(30.0, gt=0)
    health_interval_s: float = Field(15.0, gt=0)
    # A robot refuses to start while a server that posts events has no secret (its events
    # would all be rejected with 401): every entry with an event_secret key must have a value.
    require_event_secrets: bool = False
    # A robot never talks to a server over HTTP without that server's credential (the server
    # would answer 401 anyway): every sse / streamable_http entry must have its auth_token.
    require_mcp_credentials: bool = False

    @model_validator(mode="after")
    def _credentials_present(self) -> McpToolsConfig:
        if self.require_mcp_credentials:
            missing = self.servers_without_credential()
            if missing:
                raise ValueError(
                    f"MCP servers without a credential: {', '.join(missing)}; set the "
                    "variables their auth_token names in config/tools/mcp.yaml "
                    "(e.g. NAVIGATION_MCP_TOKEN = that server's MCP_AUTH_TOKEN) in .env"
                )
        return self

    def servers_without_credential(self) -> list[str]:
        """HTTP servers the brain has no credential for (they will refuse it with 401)."""
        return [s.name for s in self.servers if s.needs_credential and s.auth_token is None]

    @model_validator(mode="after")
    def _secrets_present(self) -> McpToolsConfig:
        if self.require_event_secrets:
            missing = [
                s.name for s in self.servers if s.event_secret is not None and not s.can_post_events
            ]
            if missing:
                raise ValueError(
                    f"servers without an event secret: {', '.join(missing)}; set the "
                    "variables their event_secret names in config/tools/mcp.yaml "
                    "(e.g. NAV_EVENT_SECRET) in .env"
                )
        return self

    def servers_without_event_secret(self) -> list[str]:
        """Servers that post events (an ``event_secret`` entry) but have no secret to sign
        with; servers that never post (memory, skill_control) are not listed."""
        return [
            s.name for s in self.servers if s.event_secret is not None and not s.can_post_events
        ]

    @field_validator("servers")
    @classmethod
    def _unique(cls, servers: list[McpServerConfig]) -> list[McpServerConfig]:
        names = [s.name for s in servers]
        if len(names) != len(set(names)):
            raise ValueError(f"duplicate MCP server names in {names}")
        for s in servers:
            if s.transport == "stdio" and not s.command:
                raise ValueError(f"server {s.name}: stdio needs a command")
            if s.transport != "stdio" and not s.url:
                raise ValueError(f"server {s.name}: {s.transport} needs a url")
        return servers


class ApiConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    event_rate_limit: str = "120/minute"
    unsigned_rate_limit: str = "30/minute"
    # per client address, every HTTP route but the signed ingress; one open UI polls ~400/min
    default_rate_limit: str = "3000/minute"
    max_event_body_bytes: int = Field(65536, gt=0)
    # every other request body (login, chat, approvals); larger ones are 413, unread
    max_body_bytes: int = Field(65536, gt=0)
    # deeper events are refused (400): nothing legitimate nests this far, and deep nesting
    # overflows the stack of whatever walks the payload later (json, pydantic, the trace)
    max_event_json_depth: int = Field(32, ge=2)
    dedupe_size: int = Field(4096, gt=0)
    signature_tolerance_s: float = 300
    cors_origins: list[str] = Field(default_factory=list)
    # Host names the brain answers to (port ignored; "*" = any). Anything else is refused:
    # a DNS-rebinding page reaches the brain under its own name.
    trusted_hosts: list[str] = Field(default_factory=lambda: ["localhost", "127.0.0.1", "::1"])

    @field_validator("event_rate_limit", "unsigned_rate_limit", "default_rate_limit")
    @classmethod
    def _rate(cls, limit: str) -> str:
        try:
            parse(limit)
        except ValueError as exc:
            raise ValueError(f"rate limit {limit!r} is not like '120/minute'") from exc
        return limit

    @field_validator("cors_origins")
    @classmethod
    def _exact_origins(cls, origins: list[str]) -> list[str]:
        """Socket.IO allow-list beyond same-origin: exact ``scheme://host[:port]`` entries."""
        for origin in origins:
            if not re.fullmatch(r"https?://[^/\s*]+", origin):
                raise ValueError(
                    f"api.cors_origins entry {origin!r} must be an exact origin such as "
                    "https://console.example.org (no wildcard, no path)"
                )
        return origins


class ChatConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    system_prompt: str = "You are the voice of a friendly service robot. Answer briefly."
    max_tool_rounds: int = Field(4, ge=1)
    history_turns: int = Field(10, ge=0)
    turn_timeout_s: float = Field(60.0, gt=0)
    # "I'm busy" for a mission that is already running is said aloud once per burst: again
    # only after this long without one (each turn still gets it on screen; issue 39)
    busy_reply_repeat_s: float = Field(30.0, ge=0)
    # What people say first when they talk to the robot's own microphone ("robbie"): without
    # it an utterance is not a turn (chatter nearby); "stop" needs none. Empty: none needed.
    # Push-to-talk in the browser never needs it.
    wake_phrase: str = Field("", max_length=40, pattern=r"^[A-Za-z' ]*$")
    # Tools of motion servers the fast path may call (they do not move the robot).
    motion_read_tools: list[str] = Field(
        default_factory=lambda: ["get_pose", "list_locations", "get_task", "list_tasks"]
    )


class AuthConfig(BaseModel):
    """Operator login (ARCHITECTURE §6). Secrets come from the environment (``ADMIN_*``)."""

    model_config = ConfigDict(extra="forbid")

    enabled: bool = False
    session_ttl_s: int = Field(12 * 3600, gt=0)
    cookie_name: str = "rvc_session"
    # auto: Secure when the request arrived over https (directly or via a trusted proxy).
    cookie_secure: Literal["auto", "always", "never"] = "auto"
    login_max_failures: int = Field(5, ge=1)
    login_window_s: float = Field(300, gt=0)
    # argon2 checks running at once (each ~64 MiB) and queued behind them; more → 429
    login_concurrency: int = Field(2, ge=1)
    login_queue: int = Field(8, ge=0)
    # Peers whose X-Forwarded-For/-Proto are believed besides the proxy socket (a proxy on
    # another host). Never loopback on a robot: every local process has that address.
    trusted_proxies: list[str] = Field(default_factory=list)


class UiConfig(BaseModel):
    """The operator's web app: where its build lives and what the brain proxies for it."""

    model_config = ConfigDict(extra="forbid")

    static_dir: str = ""  # "" = the package's static/ (built by `make setup`)
    camera_url: str = "http://127.0.0.1:9112"  # the vision node's artifacts server
    # The vision node's ARTIFACTS_AUTH_TOKEN (VISION_ARTIFACTS_TOKEN): its pictures need it;
    # empty = none (the node then refuses the frame and the UI shows the camera offline).
    camera_token: SecretStr | None = None
    camera_timeout_s: float = Field(2.0, gt=0)
    camera_max_bytes: int = Field(8 * 1024 * 1024, gt=0)  # larger frames are refused
    chat_history_size: int = Field(50, ge=0)
    tool_timeout_s: float = Field(3.0, gt=0)  # pose / locations / detections for the UI

    @field_validator("camera_token")
    @classmethod
    def _camera_token(cls, token: SecretStr | None) -> SecretStr | None:
        value = token.get_secret_value().strip() if token is not None else ""
        return SecretStr(value) if value else None


class ControlConfig(BaseModel):
    """Operator control of motion: the tool policy file and approvals (issue 21)."""

    model_config = ConfigDict(extra="forbid")

    policy_file: str = "config/policy.yaml"
    approval_timeout_s: float = Field(60.0, gt=0)  # no answer within this → denied
    audit_log: str = ""  # "" = <data_dir>/approvals.jsonl (append-only)
    # issue 27: the lease on every motion server (renewed every period, lapses after the TTL;
    # a brain killed mid-drive halts the robot within about one TTL). Issue 39: renewed from a
    # thread of its own; measured (benchmarks/supervision_jitter.py, shared 2-core machine)
    # the gap between answered renewals is p50 252 / p99 400 / max 576 ms with the stack idle
    # at load 12, p99 354 / max 547 ms under two busy loops + missions + bursts of 20 chat
    # turns (load 7-9): a 0.8 s TTL leaves >= 224 ms over the worst gap, and a longer one would
    # break the 1 s bound on brain kill -9 -> halted (p99 0.96 s with 0.8). The servers' own
    # starvation grace stays 0.25 s (robot_mcp_kit.supervision_tools.STARVED_GRACE_S).
    lease_period_s: float = Field(0.25, gt=0, le=1.0)
    lease_ttl_s: float = Field(0.8, gt=0, le=2.0)
    # a brain whose loop has not run for this long is hung, not busy: the renewal thread stops
    # renewing and the robot halts as for a dead brain (the loop's worst stall measured under
    # two busy loops: see readyz data.supervision.renewals.loop_lag_max_ms)
    lease_hung_s: float = Field(5.0, gt=0, le=60.0)
    # where the renewals run: a thread of the brain (default) or a small child process with its
    # own connections (benchmarks/supervision_jitter.py --runners process,thread, two busy loops
    # + missions + chat bursts, load 7-12: the process starts its renewals on time more often,
    # lateness p50 1.0-1.6 vs 2.1-3.5 ms, p99 18-40 vs 29-94 ms, but it was not clearly fewer
    # lapses with the brain alive (13 in 4 phases, 12 of them in one phase while the whole host
    # stalled, vs 0 in 4), so the thread stays the default until more runs say otherwise)
    lease_runner: Literal["process", "thread"] = "thread"

    @model_validator(mode="after")
    def _period_within_ttl(self) -> ControlConfig:
        if self.lease_period_s > self.lease_ttl_s / 2:
            raise ValueError("lease_period_s must be at most half of lease_ttl_s")
        return self


class AppConfig(BaseModel):
    """The composed tree. Adapter groups stay dicts with ``_target_`` (built by Hydra)."""

    model_config = ConfigDict(extra="forbid")

    deployment: str = "dev"
    llm: dict[str, Any]
    llm_planner: dict[str, Any] | None = None
    speech_output: dict[str, Any]
    speech_input: dict[str, Any]
    tools: McpToolsConfig = Field(default_factory=McpToolsConfig)
    agent: AgentConfig = Field(default_factory=AgentConfig)
    api: ApiConfig = Field(default_factory=ApiConfig)
    chat: ChatConfig = Field(default_factory=ChatConfig)
    auth: AuthConfig = Field(default_factory=AuthConfig)
    ui: UiConfig = Field(default_factory=UiConfig)
    control: ControlConfig = Field(default_factory=ControlConfig)

    @field_validator("llm", "speech_output", "speech_input")
    @classmethod
    def _has_target(cls, group: dict[str, Any]) -> dict[str, Any]:
        if "_target_" not in group:
            raise ValueError("adapter config needs a _target_")
        return group


def data_dir(agent: AgentConfig) -> Path:
    if agent.data_dir:
        return Path(agent.data_dir).expanduser()
    return Path(platformdirs.user_data_dir("robot-voice-chat", appauthor=False))


def state_path(agent: AgentConfig, configured: str, default_name: str) -> Path:
    """A configured state path, else ``default_name`` in the data dir (never the CWD)."""
    return resolve_path(configured) if configured else data_dir(agent) / default_name


def resolve_path(path: str) -> Path:
    """Relative paths in config are relative to the package dir (config/…) or the CWD (data)."""
    p = Path(path)
    if p.is_absolute():
        return p
    return PACKAGE_DIR / p if p.parts[:1] == ("config",) else Path.cwd() / p
