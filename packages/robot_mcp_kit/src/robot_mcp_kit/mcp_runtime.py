"""MCP server plumbing shared by the capability servers: the transport switch and tool errors.

Tool errors: a tool raises ``tool_error(code, detail)``. The SDK turns that into a tool result
with ``isError: true`` whose text is ``Error executing tool <name>: <message>``;
:func:`install_json_tool_errors` (done by :func:`run_server`) adds a server middleware that
strips that prefix, so the client reads exactly ``{"error": code, "detail": detail}``. Other
tool failures (bad arguments, crashes) become ``{"error": "tool_error", "detail": <text>}``.
:func:`parse_tool_error` reads either form on the client side.

Credentials: over sse / streamable-http every request must carry the server's credential
(:mod:`robot_mcp_kit.service_auth`, ``MCP_AUTH_TOKEN``); :func:`transport_settings` reads and
checks it with the transport, :func:`serve_mcp` puts the check in front of the whole app.

Approvals: ``MCP_APPROVAL_SECRET`` (optional, any transport, >= 32 bytes) is the secret this
server shares with the brain for signed approvals (:mod:`robot_mcp_kit.approvals`);
:func:`serve_mcp` installs the verifier, and a tool asks for one with ``require_approval()``.
Without it the server accepts no approval (its approval-gated tools refuse every call).

Stdio: :func:`reserve_stdout` keeps the process's standard output for JSON-RPC alone, for
the whole life of the process — native libraries (rcl, Fast DDS) that write to fd 1 at start-up
or shutdown, outside the SDK's own serving window, land on stderr.
"""

from __future__ import annotations

import io
import json
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, BinaryIO, Literal, get_args

import anyio
import structlog
from mcp.server.context import CallNext, HandlerResult, ServerRequestContext
from mcp.server.mcpserver import MCPServer
from mcp.server.mcpserver.exceptions import ToolError
from mcp.server.stdio import stdio_server
from pydantic import SecretStr

from robot_mcp_kit.approvals import ENV_APPROVAL_SECRET, ApprovalVerifier
from robot_mcp_kit.caller import install_caller_context
from robot_mcp_kit.correlation import install_mission_correlation
from robot_mcp_kit.http_serving import serve_http
from robot_mcp_kit.service_auth import BearerAuthMiddleware, ServiceAuth, service_auth
from robot_mcp_kit.startup import refuse_to_start
from robot_mcp_kit.tool_errors import parse_tool_error as parse_tool_error

Transport = Literal["stdio", "sse", "streamable-http"]
TRANSPORTS: tuple[Transport, ...] = get_args(Transport)
DEFAULT_HOST = "127.0.0.1"
GENERIC_TOOL_ERROR = "tool_error"

logger = structlog.get_logger("robot_mcp_kit.mcp_runtime")


class KitToolError(ToolError):
    """A tool failure the model can read: ``str(err)`` is ``{"error": code, "detail": ...}``."""

    def __init__(self, code: str, detail: str) -> None:
        self.code = code
        self.detail = detail
        super().__init__(json.dumps({"error": code, "detail": detail}, ensure_ascii=False))


def tool_error(code: str, detail: str) -> KitToolError:
    """The exception a tool raises for an anticipated failure: ``raise tool_error(...)``."""
    return KitToolError(code, detail)


def _as_json_error(text: str) -> str:
    parsed = parse_tool_error(text)
    if parsed is None:
        parsed = {"error": GENERIC_TOOL_ERROR, "detail": text}
    return json.dumps(parsed, ensure_ascii=False)


class JsonToolErrors:
    """Server middleware: every ``tools/call`` error result carries JSON text only."""

    async def __call__(
        self, ctx: ServerRequestContext[Any, Any], call_next: CallNext
    ) -> HandlerResult:
        result = await call_next(ctx)
        if ctx.method != "tools/call" or not isinstance(result, dict):
            return result
        if not (result.get("isError") or result.get("is_error")):
            return result
        content = result.get("content")
        if not isinstance(content, list):
            return result
        rewritten: list[Any] = []
        for block in content:
            if isinstance(block, dict) and block.get("type") == "text":
                block = {**block, "text": _as_json_error(str(block.get("text", "")))}
            rewritten.append(block)
        return {**result, "content": rewritten}


def install_json_tool_errors(server: MCPServer) -> MCPServer:
    """Add :class:`JsonToolErrors` to ``server`` (once); returns the server."""
    if not any(isinstance(m, JsonToolErrors) for m in server.middleware):
        server.middleware.append(JsonToolErrors())
    return server


@dataclass(frozen=True)
class TransportSettings:
    transport: Transport
    host: str
    port: int
    auth: ServiceAuth | None = None
    """The credentials an HTTP transport demands; None = read them from the environment
    when serving (:func:`robot_mcp_kit.service_auth.service_auth`)."""
    approval_secret: SecretStr | None = None
    """``MCP_APPROVAL_SECRET``: the key of the approvals this server accepts (None = none)."""


def transport_settings(env: Mapping[str, str], default_port: int) -> TransportSettings:
    """Read ``MCP_TRANSPORT`` (stdio | sse | streamable-http, default stdio), ``MCP_HOST``
    (default 127.0.0.1), ``MCP_PORT`` (default ``default_port``) and, for the HTTP
    transports, the credentials (``MCP_AUTH_TOKEN``, ``MCP_OPERATOR_TOKEN``, ``MCP_AUTH``), and
    ``MCP_APPROVAL_SECRET``. Raises ``ValueError`` (one readable sentence) for anything
    unusable."""
    transport = env.get("MCP_TRANSPORT", "stdio").strip().lower() or "stdio"
    if transport not in TRANSPORTS:
        raise ValueError(f"MCP_TRANSPORT must be one of {', '.join(TRANSPORTS)}; got {transport!r}")
    host = env.get("MCP_HOST", DEFAULT_HOST).strip() or DEFAULT_HOST
    port_text = env.get("MCP_PORT", "").strip()
    try:
        port = int(port_text) if port_text else default_port
    except ValueError:
        raise ValueError(f"MCP_PORT must be an integer, got {port_text!r}") from None
    if not 0 < port < 65536:
        raise ValueError(f"MCP_PORT must be in 1..65535, got {port}")
    auth = service_auth(env, transport)
    secret = env.get(ENV_APPROVAL_SECRET, "").strip()
    if secret:
        ApprovalVerifier("-", secret)  # raises ApprovalConfigError (a ValueError) when short
    return TransportSettings(transport, host, port, auth, SecretStr(secret) if secret else None)


def reserve_stdout() -> BinaryIO:
    """Take fd 1 for the MCP wire and point fd 1 (and ``sys.stdout``) at stderr for the rest
    of the process. Call it first thing in a stdio server's entry point, before anything that
    may print (ROS start-up); pass the result to :func:`run_server` / :func:`serve_mcp`."""
    sys.stdout.flush()
    wire = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return wire


async def _serve_stdio(server: MCPServer, wire: BinaryIO) -> None:
    text = io.TextIOWrapper(wire, encoding="utf-8", newline="\n")
    async with stdio_server(stdout=anyio.wrap_file(text)) as (read_stream, write_stream):
        # MCPServer.run_stdio_async without its own stdout claim (the SDK has no public
        # hook to hand it the reserved wire).
        lowlevel = server._lowlevel_server
        await lowlevel.run(read_stream, write_stream, lowlevel.create_initialization_options())


async def serve_mcp(
    server: MCPServer, settings: TransportSettings, wire: BinaryIO | None = None
) -> None:
    """Serve ``server`` on ``settings``' transport until it stops (for servers that need to
    run their own start-up and shutdown around the transport, inside one event loop).
    ``wire``: the stdout reserved by :func:`reserve_stdout` (stdio only). Over sse and
    streamable-http every request must present ``settings.auth``'s credential; approvals
    are checked with ``settings.approval_secret``."""
    install_json_tool_errors(server)
    install_mission_correlation(server)
    secret = settings.approval_secret
    install_caller_context(
        server,
        ApprovalVerifier(server.name, secret.get_secret_value()) if secret is not None else None,
    )
    if settings.transport == "stdio" and wire is not None:
        await _serve_stdio(server, wire)
    elif settings.transport == "stdio":
        await server.run_stdio_async()
    else:
        await _serve_http(server, settings)


def http_app(server: MCPServer, settings: TransportSettings) -> Any:
    """The ASGI app of ``server`` on an HTTP transport, behind its credential check."""
    if settings.transport == "sse":
        app: Any = server.sse_app(host=settings.host)
    else:
        app = server.streamable_http_app(host=settings.host)
    auth = settings.auth
    if auth is None:
        auth = service_auth(os.environ, settings.transport)
    if not auth.enabled:
        logger.warning(
            "mcp_auth_disabled",
            server=server.name,
            detail="MCP_AUTH=off: any local process may call this server's tools",
        )
        return app
    return BearerAuthMiddleware(app, auth, server.name)


async def _serve_http(server: MCPServer, settings: TransportSettings) -> None:
    # what MCPServer.run_sse_async / run_streamable_http_async do, with the check in front,
    # and a stop that returns (robot_mcp_kit.http_serving, issue 31)
    level = str(server.settings.log_level).lower()
    app = http_app(server, settings)
    stopped_by = await serve_http(app, settings.host, settings.port, level)
    logger.info("mcp_server_stopped", transport=settings.transport, signal=stopped_by)


def run_server(server: MCPServer, default_port: int, wire: BinaryIO | None = None) -> None:
    """Run ``server`` on the transport chosen by the environment (blocks until it stops; a
    stop signal returns normally, so the caller's cleanup runs and nothing is printed but
    one ``mcp_server_stopped`` line); unusable transport or credential settings exit 2 with
    one line, never a traceback."""
    try:
        settings = transport_settings(os.environ, default_port)
    except ValueError as error:
        refuse_to_start(server.name, error)
    try:
        anyio.run(serve_mcp, server, settings, wire)
    except KeyboardInterrupt:  # Ctrl+C outside uvicorn's own handling (start-up, stdio)
        logger.info("mcp_server_stopped", transport=settings.transport, signal="SIGINT")
