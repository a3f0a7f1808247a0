"""FastAPI app factory + the combined Socket.IO ASGI app."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import socketio
from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError

from robot_voice_chat.api import auth_routes
from robot_voice_chat.api.auth_middleware import OperatorAuthMiddleware
from robot_voice_chat.api.body_limit import (
    BodyLimitMiddleware,
    SocketIOBodyLimit,
    validation_error,
)
from robot_voice_chat.api.container import Container
from robot_voice_chat.api.forwarded import ForwardedFromProxy
from robot_voice_chat.api.middleware import RequestContextMiddleware
from robot_voice_chat.api.rate_limit import DefaultRateLimitMiddleware
from robot_voice_chat.api.request_guard import RequestGuard
from robot_voice_chat.api.routes import (
    agent,
    approvals,
    camera,
    chat,
    chat_history,
    health,
    history,
    robot_arm,
    robot_map,
    safety,
    ui,
)
from robot_voice_chat.api.security_headers import SecurityHeadersMiddleware
from robot_voice_chat.api.socket import register_handlers
from robot_voice_chat.api.socket_sessions import SocketSessions


def _guard_options(container: Container) -> dict[str, Any]:
    return {
        "trusted_hosts": container.config.api.trusted_hosts,
        "allowed_origins": container.config.api.cors_origins,
        "login_enabled": container.auth is not None,
    }


def create_app(
    container: Container, *, manage_lifecycle: bool = True, guard: bool = True
) -> FastAPI:
    """The FastAPI app; ``guard=False`` when the caller puts the guard around it (and
    Socket.IO) itself, as :func:`create_asgi_app` does."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if manage_lifecycle:
            await container.start()
        try:
            yield
        finally:
            if manage_lifecycle:
                await container.stop()

    app = FastAPI(title="robot-voice-chat", lifespan=lifespan)
    app.state.container = container
    if container.auth is not None:
        app.add_middleware(OperatorAuthMiddleware, auth=container.auth)
    app.add_middleware(
        DefaultRateLimitMiddleware,
        limit=container.config.api.default_rate_limit,
        exempt_paths=[agent.EVENTS_PATH],  # the ingress keeps its own limits
    )
    app.add_middleware(
        BodyLimitMiddleware,
        default=container.config.api.max_body_bytes,
        limits=chat.BODY_LIMITS,  # a recorded turn is larger
        exempt_paths=frozenset({agent.EVENTS_PATH}),  # it refuses its own (max_event_body_bytes)
    )
    app.add_exception_handler(RequestValidationError, validation_error)
    app.add_middleware(RequestContextMiddleware)
    if guard:
        app.add_middleware(RequestGuard, **_guard_options(container))
        app.add_middleware(SecurityHeadersMiddleware)
    sessions = (
        SocketSessions(container.sio, container.auth)
        if container.sio is not None and container.auth is not None
        else None
    )
    app.state.socket_sessions = sessions
    app.include_router(
        auth_routes.build_router(
            container.auth, sessions.close_session if sessions is not None else None
        )
    )
    app.include_router(health.router)
    app.include_router(chat.router)
    app.include_router(safety.router)
    app.include_router(approvals.router)
    app.include_router(agent.build_router(container.config.api, container.seen_events))
    for router in (
        chat_history.router,
        camera.router,
        robot_map.router,
        robot_arm.router,
        history.router,
        ui.router,
    ):
        app.include_router(router)
    ui.mount_ui(app, ui.static_dir(container.config.ui.static_dir))  # last: "/" catch-all
    return app


def create_asgi_app(container: Container) -> Any:
    """The served app: Socket.IO at /socket.io, everything else FastAPI."""
    app = create_app(container, guard=False)
    served: Any = app
    if container.sio is not None:
        register_handlers(container, app.state.socket_sessions)
        served = socketio.ASGIApp(container.sio, other_asgi_app=app, socketio_path="socket.io")
        # Socket.IO requests never reach FastAPI's middleware: gate them here as well.
        if container.auth is not None:
            served = OperatorAuthMiddleware(served, container.auth)
        # ... their bodies too, before anything else (as FastAPI's BodyLimitMiddleware is)
        served = SocketIOBodyLimit(served, limit=container.config.api.max_body_bytes)
    guarded = SecurityHeadersMiddleware(RequestGuard(served, **_guard_options(container)))
    return ForwardedFromProxy(guarded, container.config.auth.trusted_proxies)
