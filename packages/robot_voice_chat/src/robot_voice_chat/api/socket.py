"""Socket.IO handlers (client → server): ``send_message`` and ``stop_pipeline``.

With operator login on, each connection is bound to the session it was opened with
(:class:`SocketSessions`): every event re-checks that session, and a logged-out or expired
session's sockets are disconnected."""

from __future__ import annotations

import asyncio
from typing import Any

import socketio
import structlog
from pydantic import ValidationError

from robot_voice_chat.api.container import Container
from robot_voice_chat.api.routes.safety import safety_view
from robot_voice_chat.api.socket_sessions import SocketSessions
from robot_voice_chat.socket_events import SendMessage

logger = structlog.get_logger(__name__)
LOGIN_REQUIRED = {"ok": False, "error": "login required"}


async def end_socket_sessions(sio: Any) -> None:
    """Close every Socket.IO client (the brain is stopping): a long-polling client's held GET
    is answered at once instead of holding the server's graceful stop (issue 35: 13.5 s); the
    UI reconnects to the next brain by itself."""
    if sio is None:
        return
    count = len(sio.eio.sockets)
    if count:
        await sio.eio.disconnect()
        logger.info("socket_sessions_ended", count=count)


def register_handlers(container: Container, sessions: SocketSessions | None = None) -> None:
    sio = container.sio
    turns: set[asyncio.Task[Any]] = set()

    def session_ended(sid: str) -> bool:
        """True (and the socket closing) when ``sid``'s session is no longer valid."""
        if sessions is None or sessions.valid(sid):
            return False
        sessions.close_soon(sid, "session_invalid")
        return True

    @sio.event  # type: ignore[untyped-decorator]
    async def connect(sid: str, environ: dict[str, Any], auth: Any = None) -> None:
        if sessions is not None and sessions.attach(sid, environ) is None:
            raise socketio.exceptions.ConnectionRefusedError("login required")
        logger.info("socket_connected", sid=sid)
        await sio.emit("teaching_state", {"armed": container.teaching.armed}, to=sid)
        await sio.emit("safety_state", safety_view(container).model_dump(), to=sid)

    @sio.event  # type: ignore[untyped-decorator]
    async def disconnect(sid: str, *_: Any) -> None:
        if sessions is not None:
            sessions.detach(sid)

    @sio.event  # type: ignore[untyped-decorator]
    async def send_message(sid: str, data: Any) -> dict[str, Any]:
        if session_ended(sid):
            return LOGIN_REQUIRED
        try:
            message = SendMessage.model_validate(data)
        except ValidationError as exc:
            return {"ok": False, "error": exc.errors(include_url=False)[0]["msg"]}
        task = asyncio.create_task(container.pipeline.handle_turn(message.text))
        turns.add(task)
        task.add_done_callback(turns.discard)
        return {"ok": True}

    @sio.event  # type: ignore[untyped-decorator]
    async def stop_pipeline(sid: str, data: Any = None) -> dict[str, Any]:
        if session_ended(sid):
            return LOGIN_REQUIRED
        await container.pipeline.stop("Stop robot (operator UI)")
        return {"ok": True}
