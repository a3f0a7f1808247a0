"""How a motion server process runs (navigation, manipulation): its app's wiring
(:class:`MotionWiring`: the event sink, supervision, the dead-man lock, the cancel-all of every
goal below, what closes the ROS side), the composition root's ``running()`` block (the event
sink, the supervision watchdog, and on exit: halt, flush, close) and the console script's
``main`` (settings, logging, credentials, the app; a bad start-up is exit 2 with one
``startup_failed`` line; SIGTERM takes Ctrl-C's path).
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Mapping
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any, BinaryIO, Literal, Protocol, Self, TypeVar

import structlog
from mcp.server.mcpserver import MCPServer
from pydantic import SecretStr

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import TransportSettings, reserve_stdout, serve_mcp
from robot_mcp_kit.service_auth import ServiceAuth, ServiceAuthError, service_auth
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.supervision_tools import supervising
from robot_mcp_kit.task_events import EventSink, build_event_sink

logger = structlog.get_logger(__name__)


class MotionService(Protocol):
    """What the watchdog and shutdown need of a motion service (``Navigator``, ...)."""

    @property
    def moving(self) -> bool: ...

    async def stop(self, reason: str) -> object: ...

    async def close(self) -> None: ...


@asynccontextmanager
async def motion_running(
    name: str,
    events: EventSink,
    service: MotionService,
    *,
    supervision: Supervision | None = None,
    publish_lock: Callable[[], object] | None = None,
    cancel_all: Callable[[], Awaitable[bool]] | None = None,
    closers: list[Callable[[], None]] | None = None,
    prepare: Callable[[], Awaitable[object]] | None = None,
    ready: Mapping[str, Any] | None = None,
) -> AsyncIterator[None]:
    """Start the event sink (then ``prepare()``, e.g. a sweep of stale goals before a lease can
    open the lock) and the supervision watchdog; log ``<name>_ready`` with ``ready``. On exit
    halt the robot, flush the events, close the ROS side (``closers``), log ``<name>_shutdown``."""
    started = time.monotonic()
    await events.start()
    if prepare is not None:
        await prepare()
    try:
        async with supervising(
            supervision, service.stop, lambda: service.moving, publish_lock, cancel_all
        ):
            logger.info(
                f"{name}_ready",
                **(ready or {}),
                duration_ms=round((time.monotonic() - started) * 1000, 1),
            )
            yield
    finally:
        try:
            await service.close()
            await events.close()
        finally:
            for close in closers or ():
                close()
        logger.info(f"{name}_shutdown")


class SupervisionSettings(Protocol):
    @property
    def supervision(self) -> Literal["required", "off"]: ...

    @property
    def lease_max_ttl_s(self) -> float: ...


def motion_supervision(settings: SupervisionSettings, *, below: bool) -> Supervision:
    """The brain's lease over this server (issue 27), required unless its setting is ``off``.
    ``below``: a robot's action servers are below it (not a fake): then every stop of a
    supervised server cancels all their goals, and the lock opens again only after that sweep
    (issue 35)."""
    required = settings.supervision == "required"
    return Supervision(
        required=required, max_ttl_s=settings.lease_max_ttl_s, sweeps=required and below
    )


class EventSettings(Protocol):
    @property
    def events_url(self) -> str: ...

    @property
    def event_secret(self) -> SecretStr | None: ...

    @property
    def outbox_path(self) -> Path: ...


def motion_event_sink(server: str, settings: EventSettings, brain_secret_env: str) -> EventSink:
    """Signed posts to the brain when a secret is configured, else log-only (documented);
    ``brain_secret_env``: the brain's variable a log-only sink names."""
    return build_event_sink(
        server, settings.events_url, settings.event_secret, settings.outbox_path, brain_secret_env
    )


@dataclass(frozen=True)
class MotionSide:
    """What a server's ROS side gives its app: how to close it and, supervised, the dead-man
    lock published now and the cancel-all of every goal below (issue 35)."""

    close: Callable[[], None]
    publish_lock: Callable[[], object] | None = None
    cancel_all: Callable[[], Awaitable[bool]] | None = None


@dataclass(kw_only=True)
class MotionWiring:
    """The base of a motion server's app (a dataclass): what runs beside its service, and
    :meth:`running`. ``name`` prefixes the ``_ready`` / ``_shutdown`` log lines (with
    ``ready``); ``prepare`` runs once the event sink started (a sweep of stale goals)."""

    name: str
    service: MotionService
    events: EventSink
    supervision: Supervision | None = None
    side: MotionSide | None = None  # None: no ROS side (a simulated base, a test's fake)
    ready: Mapping[str, Any] = field(default_factory=dict)
    prepare: Callable[[], Awaitable[object]] | None = None

    @property
    def closers(self) -> list[Callable[[], None]]:
        return [self.side.close] if self.side is not None else []

    @asynccontextmanager
    async def running(self) -> AsyncIterator[Self]:
        """:func:`motion_running` with this wiring; yields the app."""
        side = self.side
        async with motion_running(
            self.name,
            self.events,
            self.service,
            supervision=self.supervision,
            publish_lock=side.publish_lock if side is not None else None,
            cancel_all=side.cancel_all if side is not None else None,
            closers=self.closers,
            prepare=self.prepare,
            ready=self.ready,
        ):
            yield self


class ServingSettings(Protocol):
    @property
    def transport(self) -> Literal["stdio", "sse", "streamable-http"]: ...

    @property
    def host(self) -> str: ...

    @property
    def port(self) -> int: ...

    @property
    def log_level(self) -> str: ...


class MotionApp(Protocol):
    @property
    def settings(self) -> ServingSettings: ...

    @property
    def server(self) -> MCPServer: ...

    def running(self) -> AbstractAsyncContextManager[Any]: ...


S = TypeVar("S", bound=ServingSettings)


async def serve(
    app: MotionApp, wire: BinaryIO | None = None, auth: ServiceAuth | None = None
) -> None:
    """Run the MCP transport until it stops; the robot is halted and events flushed after.
    ``wire``: stdio's reserved fd 1; ``auth``: the HTTP credentials (None: from the env)."""
    settings = app.settings
    async with app.running():
        logger.info(
            "mcp_server_starting",
            transport=settings.transport,
            host=settings.host,
            port=settings.port,
        )
        await serve_mcp(
            app.server,
            TransportSettings(settings.transport, settings.host, settings.port, auth),
            wire,
        )


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def run_motion_server(
    name: str,
    load_settings: Callable[[Mapping[str, str]], S],
    build_app: Callable[[S], MotionApp],
    startup_errors: tuple[type[Exception], ...],
    *,
    reserve_wire: bool = False,
) -> None:
    """A motion server's console script. ``startup_errors`` (with ServiceAuthError) exit 2;
    ``reserve_wire``: over stdio, fd 1 is the JSON-RPC wire alone (a ROS side's native
    start-up output goes to stderr)."""
    wire: BinaryIO | None = None
    refused: tuple[type[Exception], ...] = (*startup_errors, ServiceAuthError)
    try:
        settings = load_settings(os.environ)
        configure_logging(name, level=settings.log_level)
        auth = service_auth(os.environ, settings.transport)
        wire = reserve_stdout() if reserve_wire and settings.transport == "stdio" else None
        app = build_app(settings)
    except refused as exc:
        configure_logging(name)
        logger.error("startup_failed", detail=str(exc))
        sys.exit(2)
    # SIGTERM (systemd stop) takes the same clean path as Ctrl-C: halt, flush, exit.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        asyncio.run(serve(app, wire, auth))
    except KeyboardInterrupt:
        logger.info(f"{name}_interrupted")
