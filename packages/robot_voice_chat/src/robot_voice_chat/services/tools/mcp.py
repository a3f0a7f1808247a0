"""McpToolBackend: MCP servers from ``config/tools/mcp.yaml`` behind the ToolBackend port.

One supervisor task per server owns its ClientSession (anyio contexts are entered and left in
the same task). It connects, lists tools, health-checks with ``list_tools`` and, when a
connection fails or drops, retries every ``reconnect_interval_s`` — servers may start in any
order and restart at any time. Every (re)connect runs the connect listeners (§5.4), every
loss of a connected server the disconnect listeners (a mission told its server is gone).

Over sse / streamable-http every request carries the server's credential
(``Authorization: Bearer <auth_token>``); a refusal is logged ``mcp_server_unauthorized``
naming the setting to fix. A call an operator approved carries that approval in its ``_meta``,
next to the mission id: signed with the server's ``approval_secret`` for the name the server
announced at initialize, valid 120 s, single use (``robot_mcp_kit.approvals``). Without an
``approval_secret`` no approval is sent (logged ``approval_unsigned``): a server that demands
one refuses the call.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import AsyncIterator, Callable
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass, field
from typing import Any, cast

import structlog
from mcp import types
from mcp.client.session import ClientRequestContext, ClientSession
from mcp.client.sse import sse_client
from mcp.client.stdio import StdioServerParameters, stdio_client
from mcp.client.streamable_http import streamable_http_client
from mcp.shared._httpx_utils import create_mcp_http_client  # the SDK's own client defaults
from mcp.types import RequestParamsMeta
from pydantic import SecretStr

from robot_mcp_kit.approvals import ENV_APPROVAL_SECRET, signed_approval
from robot_mcp_kit.correlation import mission_meta
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.tools import mcp_logs
from robot_voice_chat.services.tools.base import (
    ConnectionState,
    ElicitationHandler,
    ServerListener,
    ToolBackend,
    ToolOutcome,
    approved_call,
)
from robot_voice_chat.settings import McpServerConfig

logger = structlog.get_logger(__name__)


@dataclass
class _Connection:
    config: McpServerConfig
    state: ConnectionState = "disconnected"
    session: ClientSession | None = None
    tools: list[ToolDefinition] = field(default_factory=list)
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    task: asyncio.Task[None] | None = None
    refused: bool = False  # the last attempt met a 401/403: a credential problem
    announced: str | None = None  # the server's own name (initialize): an approval's audience


def call_meta(
    server: str,
    tool: str,
    arguments: dict[str, object],
    *,
    approval_secret: SecretStr | None = None,
    audience: str | None = None,
) -> RequestParamsMeta | None:
    """The ``_meta`` of one ``tools/call``: the mission id (bound by the executor for its run)
    and, when an operator approved exactly this call, the approval signed with
    ``approval_secret`` for ``audience`` (the server's announced name; default ``server``)."""
    meta: dict[str, Any] = dict(
        mission_meta(structlog.contextvars.get_contextvars().get("mission_id")) or {}
    )
    approved = approved_call.get()
    if (
        approved is not None
        and approved.tool == f"{server}.{tool}"
        and approved.arguments == arguments
    ):
        if approval_secret is None:
            logger.warning(
                "approval_unsigned",
                server=server,
                tool=tool,
                approval_id=approved.approval_id,
                detail=f"no approval_secret for {server} in config/tools/mcp.yaml (its "
                "MCP_APPROVAL_SECRET): the approval is not sent and the server may refuse",
            )
        else:
            meta.update(
                signed_approval(
                    approval_secret.get_secret_value(),
                    server=audience or server,
                    tool=tool,
                    arguments=arguments,
                    approval_id=approved.approval_id,
                    by=approved.by,
                )
            )
    return cast(RequestParamsMeta, meta) if meta else None


def stdio_parameters(cfg: McpServerConfig) -> StdioServerParameters:
    """How a stdio server is spawned: its command, args and env, plus ``MCP_APPROVAL_SECRET``
    when the brain holds its ``approval_secret`` (the child checks what the brain signs)."""
    assert cfg.command is not None
    env = dict(cfg.env)
    if cfg.approval_secret is not None:
        env.setdefault(ENV_APPROVAL_SECRET, cfg.approval_secret.get_secret_value())
    return StdioServerParameters(command=cfg.command, args=cfg.args, env=env or None)


def _headers(cfg: McpServerConfig) -> dict[str, str] | None:
    token = cfg.auth_token
    return {"Authorization": f"Bearer {token.get_secret_value()}"} if token is not None else None


def _http_client_factory(conn: _Connection) -> Callable[..., Any]:
    """The SDK's HTTP client, noting a 401/403 on ``conn`` (the transports report it as a
    generic error, or not at all)."""

    def make(headers: Any = None, timeout: Any = None, auth: Any = None) -> Any:
        client = create_mcp_http_client(headers=headers, timeout=timeout, auth=auth)

        async def note(response: Any) -> None:
            if response.status_code in (401, 403):
                conn.refused = True

        client.event_hooks["response"].append(note)
        return client

    return make


@asynccontextmanager
async def _streamable_http(conn: _Connection) -> AsyncIterator[Any]:
    cfg = conn.config
    assert cfg.url is not None
    make = _http_client_factory(conn)
    async with (
        make(headers=_headers(cfg)) as http,
        streamable_http_client(cfg.url, http_client=http) as streams,
    ):
        yield streams


def _result_text(result: Any) -> str:
    parts = []
    for block in getattr(result, "content", []) or []:
        text = getattr(block, "text", None)
        parts.append(text if isinstance(text, str) else json.dumps(block.model_dump(mode="json")))
    if not parts and getattr(result, "structured_content", None) is not None:
        parts.append(json.dumps(result.structured_content))
    return "\n".join(parts)


class McpToolBackend(ToolBackend):
    def __init__(
        self,
        servers: list[McpServerConfig],
        *,
        blocking_tools: list[str] | None = None,
        call_timeout_s: float = 30.0,
        connect_timeout_s: float = 10.0,
        reconnect_interval_s: float = 30.0,
        health_interval_s: float = 15.0,
        quiet_tools: frozenset[str] = frozenset(),
    ) -> None:
        self._connections = {s.name: _Connection(config=s) for s in servers}
        self.quiet_tools = quiet_tools  # logged at debug level (the lease, several per second)
        self.blocking_tools = set(blocking_tools or [])
        self._call_timeout_s = call_timeout_s
        self._connect_timeout_s = connect_timeout_s
        self._reconnect_interval_s = reconnect_interval_s
        self._health_interval_s = health_interval_s
        self._listeners: list[ServerListener] = []
        self._lost_listeners: list[ServerListener] = []
        self._closing = False
        self._listener_tasks: set[asyncio.Task[None]] = set()
        self._elicitation: ElicitationHandler | None = None
        self._transport_errors = mcp_logs.install()

    def set_elicitation_handler(self, handler: ElicitationHandler) -> None:
        """Before ``start``: sessions then declare elicitation and route questions here."""
        self._elicitation = handler

    def _elicitation_callback(self, server: str) -> Any:
        handler = self._elicitation
        if handler is None:
            return None  # the SDK's default: no capability declared, requests refused

        async def answer(
            context: ClientRequestContext, params: types.ElicitRequestParams
        ) -> types.ElicitResult | types.ErrorData:
            if not isinstance(params, types.ElicitRequestFormParams):
                return types.ErrorData(
                    code=types.INVALID_REQUEST, message="only form elicitation is supported"
                )
            schema = dict(params.requested_schema)
            action, content = await handler(server, params.message, schema)
            return types.ElicitResult(action=action, content=content)

        return answer

    # --- port ---------------------------------------------------------------------------
    def list_tools(self) -> list[ToolDefinition]:
        return [t for c in self._connections.values() if c.state == "connected" for t in c.tools]

    def servers(self) -> dict[str, McpServerConfig]:
        return {name: c.config for name, c in self._connections.items()}

    def server_states(self) -> dict[str, ConnectionState]:
        return {name: c.state for name, c in self._connections.items()}

    def add_connect_listener(self, listener: ServerListener) -> None:
        self._listeners.append(listener)

    def add_disconnect_listener(self, listener: ServerListener) -> None:
        self._lost_listeners.append(listener)

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        server, _, tool = name.partition(".")
        conn = self._connections.get(server)
        if conn is None or not tool:
            return ToolOutcome(text=f"error: unknown tool {name!r}", is_error=True)
        session = conn.session
        if conn.state != "connected" or session is None:
            return ToolOutcome(text=f"error: server {server!r} is not connected", is_error=True)
        timeout = timeout_s or self._call_timeout_s
        started = time.monotonic()
        try:
            async with asyncio.timeout(timeout):
                result = await session.call_tool(
                    tool,
                    dict(arguments),
                    read_timeout_seconds=timeout,
                    meta=call_meta(
                        server,
                        tool,
                        arguments,
                        approval_secret=conn.config.approval_secret,
                        audience=conn.announced,
                    ),
                )
        except TimeoutError:
            outcome = ToolOutcome(
                text=f"error: {name} timed out after {timeout:g} s", is_error=True, cut_off=True
            )
        except Exception as exc:
            outcome = ToolOutcome(text=f"error: {name} failed: {exc}", is_error=True, cut_off=True)
            conn.wake.set()  # let the supervisor health-check the connection now
        else:
            outcome = ToolOutcome(text=_result_text(result), is_error=bool(result.is_error))
        log = logger.debug if tool in self.quiet_tools and not outcome.is_error else logger.info
        log(
            "mcp_tool_called",
            tool=name,
            is_error=outcome.is_error,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        return outcome

    def check_now(self, server: str) -> None:
        conn = self._connections.get(server)
        if conn is not None:
            conn.wake.set()

    async def start(self) -> None:
        for conn in self._connections.values():
            conn.task = asyncio.create_task(self._supervise(conn), name=f"mcp-{conn.config.name}")

    async def aclose(self) -> None:
        self._closing = True
        tasks = [c.task for c in self._connections.values() if c.task is not None]
        for task in tasks + list(self._listener_tasks):
            task.cancel()
        if tasks:
            await asyncio.wait(tasks, timeout=5.0)

    async def wait_connected(self, server: str, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while self._connections[server].state != "connected":
            if time.monotonic() > deadline:
                raise TimeoutError(f"MCP server {server} did not connect in {timeout_s:g} s")
            await asyncio.sleep(0.05)

    # --- supervisor ---------------------------------------------------------------------
    def _transport(self, conn: _Connection) -> Any:
        cfg = conn.config
        if cfg.transport == "stdio":
            return stdio_client(stdio_parameters(cfg))
        assert cfg.url is not None
        if cfg.transport == "sse":
            return sse_client(
                cfg.url,
                headers=_headers(cfg),
                timeout=self._connect_timeout_s,
                httpx_client_factory=_http_client_factory(conn),
            )
        return _streamable_http(conn)

    async def _supervise(self, conn: _Connection) -> None:
        name = conn.config.name
        mcp_logs.current_server.set(name)  # the SDK's tasks started from here inherit it
        while not self._closing:
            conn.state, conn.refused = "connecting", False
            failure: Exception | None = None
            try:
                async with AsyncExitStack() as stack:
                    # asyncio.timeout, not wait_for: anyio scopes must stay in this task.
                    async with asyncio.timeout(self._connect_timeout_s):
                        read, write = await stack.enter_async_context(self._transport(conn))
                        session = await stack.enter_async_context(
                            ClientSession(
                                read, write, elicitation_callback=self._elicitation_callback(name)
                            )
                        )
                        initialized = await session.initialize()
                        conn.announced = initialized.server_info.name or None
                        listed = await session.list_tools()
                    conn.tools = [
                        ToolDefinition(
                            name=f"{name}.{t.name}",
                            description=t.description or "",
                            parameters=dict(t.input_schema or {"type": "object"}),
                            annotations=(
                                t.annotations.model_dump(by_alias=True, exclude_none=True)
                                if t.annotations is not None
                                else None
                            ),
                        )
                        for t in listed.tools
                    ]
                    conn.session, conn.state = session, "connected"
                    logger.info("mcp_server_connected", server=name, tools=len(conn.tools))
                    self._notify(name, self._listeners)
                    await self._health_loop(conn, session)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                failure = exc
            finally:
                lost = conn.state == "connected"
                conn.session, conn.state = None, "disconnected"
            # one line per loss or failed attempt, with the transport's reason if it had one
            reason = self._transport_errors.take(name)
            if failure is not None and not lost:
                error = reason or mcp_logs.describe(failure)
                if conn.refused:
                    logger.warning(
                        "mcp_server_unauthorized",
                        server=name,
                        error=error,
                        detail=f"{name} refused the brain's credential: its auth_token in "
                        "config/tools/mcp.yaml must equal that server's MCP_AUTH_TOKEN",
                    )
                else:
                    logger.warning("mcp_server_unavailable", server=name, error=error)
            if lost and not self._closing:
                error = reason or (mcp_logs.describe(failure) if failure else "closed")
                logger.warning("mcp_server_disconnected", server=name, error=error)
                self._notify(name, self._lost_listeners)
            if self._closing:
                break
            conn.wake.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self._reconnect_interval_s):
                    await conn.wake.wait()

    async def _health_loop(self, conn: _Connection, session: ClientSession) -> None:
        while not self._closing:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self._health_interval_s):
                    await conn.wake.wait()
            conn.wake.clear()
            async with asyncio.timeout(self._connect_timeout_s):
                await session.list_tools()

    def _notify(self, server: str, listeners: list[ServerListener]) -> None:
        for listener in listeners:
            task = asyncio.create_task(self._run_listener(listener, server))
            self._listener_tasks.add(task)
            task.add_done_callback(self._listener_tasks.discard)

    async def _run_listener(self, listener: ServerListener, server: str) -> None:
        try:
            await listener(server)
        except Exception:
            logger.exception("mcp_connect_listener_failed", server=server)
