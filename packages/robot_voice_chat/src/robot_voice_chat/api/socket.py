"""Socket.IO handlers (client → server): ``send_message`` and ``stop_pipeline``."""

from __future__ import annotations

import asyncio
from typing import Any

import structlog
from pydantic import ValidationError

from robot_voice_chat.composition import Container
from robot_voice_chat.socket_events import SendMessage

logger = structlog.get_logger(__name__)


def register_handlers(container: Container) -> None:
    sio = container.sio
    turns: set[asyncio.Task[Any]] = set()

    @sio.event  # type: ignore[untyped-decorator]
    async def connect(sid: str, environ: dict[str, Any], auth: Any = None) -> None:
        logger.info("socket_connected", sid=sid)
        await sio.emit("teaching_state", {"armed": container.teaching.armed}, to=sid)
        await sio.emit("safety_state", container.executor.latch.state.model_dump(), to=sid)

    @sio.event  # type: ignore[untyped-decorator]
    async def send_message(sid: str, data: Any) -> dict[str, Any]:
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
        await container.pipeline.stop("Stop robot (operator UI)")
        return {"ok": True}
