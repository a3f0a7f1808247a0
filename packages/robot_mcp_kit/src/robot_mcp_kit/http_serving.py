"""Serving an MCP server's HTTP app (sse / streamable-http) so that a normal stop is quiet.

Two things made every stop of a server with a connected client print tracebacks (issue 31):

- the SDK's SSE route answers a finished event stream with one more ``Response()``: a second
  ``http.response.start`` that uvicorn reports as "Exception in ASGI application" (SDK issue
  #883). :class:`OneResponse` drops that second response and ends the first one properly (a
  stream the shutdown cut has no final body: "ASGI callable returned without completing");
- uvicorn re-raises the SIGINT/SIGTERM it handled once it has shut down, so the process dies
  of the signal — a KeyboardInterrupt traceback for SIGINT, and for SIGTERM no cleanup after
  the server (a ROS bridge left open). :class:`GracefulServer` stops on the signal and returns;
  the caller logs one ``mcp_server_stopped`` line and runs its cleanup.

Session ids are not logged (issue 35 item 5): the SSE transport's messages are POSTed to
``/messages/?session_id=<id>`` and uvicorn's access log writes the query string, and the SDK's
transports name a refused session in their warnings. :class:`RedactSessionIds` (installed on
those loggers by :func:`serve_http`) writes ``session_id=<redacted>`` / ``<session>`` instead:
a session id with the credential that opened it is enough to talk in that session.
"""

from __future__ import annotations

import logging
import re
import signal
import uuid
from collections.abc import Generator
from contextlib import contextmanager
from typing import Any

import structlog
import uvicorn

logger = structlog.get_logger(__name__)
GRACEFUL_SHUTDOWN_S = 5  # then open streams are cut (systemd waits 15 s before SIGKILL)


_QUERY_SESSION = re.compile(r"(session_id=)[^&\s\"']+", re.IGNORECASE)
_SESSION_HEX = re.compile(
    r"\b[0-9a-fA-F]{32}\b|\b[0-9a-fA-F]{8}(?:-[0-9a-fA-F]{4}){3}-[0-9a-fA-F]{12}\b"
)
REDACTED_LOGGERS = (
    "uvicorn.access",
    "mcp.server.sse",
    "mcp.server.streamable_http",
    "mcp.server.streamable_http_manager",
)


def redact_session_ids(text: str) -> str:
    """``text`` with every ``session_id=<value>`` and every bare session id (32 hex digits or a
    UUID) replaced."""
    return _SESSION_HEX.sub("<session>", _QUERY_SESSION.sub(r"\1<redacted>", text))


class RedactSessionIds(logging.Filter):
    """A logging filter that rewrites a record without session ids (never drops one). The
    arguments keep their shape (uvicorn's access formatter unpacks them)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.msg, str):
            record.msg = redact_session_ids(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(_redacted_arg(arg) for arg in record.args)
        return True


def _redacted_arg(arg: object) -> object:
    if not isinstance(arg, str | uuid.UUID):
        return arg
    text = str(arg)
    redacted = redact_session_ids(text)
    return arg if redacted == text else redacted


def install_session_redaction() -> None:
    """Put :class:`RedactSessionIds` on uvicorn's access logger and the SDK's transport
    loggers (once each)."""
    for name in REDACTED_LOGGERS:
        target = logging.getLogger(name)
        if not any(isinstance(f, RedactSessionIds) for f in target.filters):
            target.addFilter(RedactSessionIds())


class OneResponse:
    """Pure ASGI: after a response has been sent in full, a further response is dropped."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = finished = dropping = False

        async def guarded(message: Any) -> None:
            nonlocal started, finished, dropping
            kind = message["type"]
            if kind == "http.response.start":
                if started:  # the SDK's extra Response() after the stream ended
                    dropping = True
                    return
                started = True
            elif kind == "http.response.body":
                if dropping:
                    return
                finished = not message.get("more_body", False)
            await send(message)

        await self.app(scope, receive, guarded)
        if started and not finished:  # a stream cut by the shutdown: end it properly
            await send({"type": "http.response.body", "body": b"", "more_body": False})


class GracefulServer(uvicorn.Server):
    """uvicorn that remembers the stop signal instead of dying of it after the shutdown."""

    stopped_by: str | None = None

    @contextmanager
    def capture_signals(self) -> Generator[None, None, None]:
        with super().capture_signals():
            yield
            captured, self._captured_signals = list(self._captured_signals), []
        if captured:
            self.stopped_by = signal.Signals(captured[-1]).name


async def serve_http(app: Any, host: str, port: int, log_level: str = "info") -> str | None:
    """Serve ``app`` until a stop signal or exit; returns the signal's name, if any."""
    config = uvicorn.Config(
        OneResponse(app),
        host=host,
        port=port,
        log_level=log_level,
        timeout_graceful_shutdown=GRACEFUL_SHUTDOWN_S,
    )
    install_session_redaction()  # after the Config, which (re)configures uvicorn's loggers
    server = GracefulServer(config)
    await server.serve()
    return server.stopped_by
