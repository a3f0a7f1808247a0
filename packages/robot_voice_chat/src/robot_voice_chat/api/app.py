"""FastAPI app factory + the combined Socket.IO ASGI app."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import socketio
from fastapi import FastAPI
from slowapi import Limiter, _rate_limit_exceeded_handler
from slowapi.errors import RateLimitExceeded

from robot_voice_chat.api import auth_routes
from robot_voice_chat.api.auth_middleware import OperatorAuthMiddleware
from robot_voice_chat.api.middleware import RequestContextMiddleware
from robot_voice_chat.api.routes import (
    agent,
    approvals,
    camera,
    chat,
    chat_history,
    health,
    robot_map,
    safety,
    ui,
)
from robot_voice_chat.api.socket import register_handlers
from robot_voice_chat.composition import Container


def _client_key(request: Any) -> str:
    client = request.client
    return client.host if client else "?"


def create_app(container: Container, *, manage_lifecycle: bool = True) -> FastAPI:
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
    limiter = Limiter(key_func=_client_key, storage_uri="memory://")
    app.state.limiter = limiter
    app.state.container = container
    app.add_exception_handler(RateLimitExceeded, _rate_limit_exceeded_handler)  # type: ignore[arg-type]
    if container.auth is not None:
        app.add_middleware(OperatorAuthMiddleware, auth=container.auth)
    app.add_middleware(RequestContextMiddleware)
    app.include_router(auth_routes.build_router(container.auth))
    app.include_router(health.router)
    app.include_router(chat.router)
    app.include_router(safety.router)
    app.include_router(approvals.router)
    app.include_router(agent.build_router(container.config.api))
    for router in (chat_history.router, camera.router, robot_map.router, ui.router):
        app.include_router(router)
    ui.mount_ui(app, ui.static_dir(container.config.ui.static_dir))  # last: "/" catch-all
    return app


def create_asgi_app(container: Container) -> Any:
    """The served app: Socket.IO at /socket.io, everything else FastAPI."""
    app = create_app(container)
    if container.sio is None:
        return app
    register_handlers(container)
    served = socketio.ASGIApp(container.sio, other_asgi_app=app, socketio_path="socket.io")
    # Socket.IO requests never reach FastAPI's middleware: gate them here as well.
    return served if container.auth is None else OperatorAuthMiddleware(served, container.auth)
