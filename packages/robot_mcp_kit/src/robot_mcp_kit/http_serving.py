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
"""

from __future__ import annotations

import signal
from collections.abc import Generator
from contextlib import contextmanager
from typing import Any

import structlog
import uvicorn

logger = structlog.get_logger(__name__)
GRACEFUL_SHUTDOWN_S = 5  # then open streams are cut (systemd waits 15 s before SIGKILL)


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
    server = GracefulServer(config)
    await server.serve()
    return server.stopped_by
