"""A real, signature-checking event receiver for tests and benchmarks of event posters.

:class:`RecordingReceiver` is a plain ASGI app that behaves like the brain's
``POST /api/agent/events`` (verify the HMAC, parse the TaskEvent, answer 200) and records every
delivery; tests can script other answers (5xx, 429, 4xx) per event. :class:`ReceiverServer`
serves it with uvicorn on 127.0.0.1 inside the running event loop and can be stopped and
started again on the same port.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Awaitable, Callable, Mapping, MutableMapping
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

import uvicorn
from pydantic import ValidationError

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import SignatureError, verify_headers

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]


@dataclass(frozen=True)
class Reply:
    status: int = 200
    headers: Mapping[str, str] = field(default_factory=dict)


Responder = Callable[[TaskEvent], Reply | None]
"""Scripted answer for an event; None means the default 200 (accepted)."""


@dataclass(frozen=True)
class Delivery:
    event: TaskEvent
    body: bytes
    received_at: float
    status: int


class RecordingReceiver:
    """ASGI app: verifies ``X-RVC-*`` signatures, records every request it answers."""

    def __init__(self, secrets: Mapping[str, str | bytes], path: str = "/api/agent/events") -> None:
        self.secrets = dict(secrets)
        self.path = path
        self.responder: Responder | None = None
        self.deliveries: list[Delivery] = []
        self.rejections: list[str] = []
        self.attempts = 0

    def accepted(self) -> list[Delivery]:
        return [d for d in self.deliveries if 200 <= d.status < 300]

    def accepted_ids(self) -> set[str]:
        return {d.event.event_id for d in self.accepted()}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            return
        body = await _read_body(receive)
        if scope["method"] != "POST" or scope["path"] != self.path:
            await _respond(send, 404, {"detail": "not found"})
            return
        self.attempts += 1
        headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
        try:
            verify_headers(headers, body, self.secrets)
        except SignatureError as exc:
            self.rejections.append(exc.reason)
            await _respond(send, 401, {"detail": exc.reason})
            return
        try:
            event = TaskEvent.model_validate_json(body)
        except ValidationError as exc:
            self.rejections.append("invalid_event")
            await _respond(send, 400, {"detail": str(exc)[:200]})
            return
        reply = (self.responder(event) if self.responder else None) or Reply()
        self.deliveries.append(Delivery(event, body, time.time(), reply.status))
        await _respond(send, reply.status, {"status": "ok"}, reply.headers)


def order_violations(deliveries: list[Delivery]) -> list[str]:
    """Problems with per-task ordering among accepted deliveries (empty when all is well):
    within a task the seq never goes back; a repeated delivery is the same event_id with the
    same bytes; no two event_ids share a task's seq."""
    problems: list[str] = []
    last_seq: dict[str, int] = {}
    bodies: dict[str, bytes] = {}
    seq_owner: dict[tuple[str, int], str] = {}
    for delivery in deliveries:
        if not 200 <= delivery.status < 300:
            continue
        event = delivery.event
        previous = last_seq.get(event.task_id, -1)
        if event.seq < previous:
            problems.append(f"task {event.task_id}: seq {event.seq} delivered after {previous}")
        last_seq[event.task_id] = max(previous, event.seq)
        if bodies.setdefault(event.event_id, delivery.body) != delivery.body:
            problems.append(f"event {event.event_id} was delivered with different bytes")
        owner = seq_owner.setdefault((event.task_id, event.seq), event.event_id)
        if owner != event.event_id:
            problems.append(f"task {event.task_id}: seq {event.seq} used by two event ids")
    return problems


async def _read_body(receive: Receive) -> bytes:
    chunks: list[bytes] = []
    while True:
        message = await receive()
        chunks.append(message.get("body", b""))
        if not message.get("more_body", False):
            return b"".join(chunks)


async def _respond(
    send: Send, status: int, payload: Any, headers: Mapping[str, str] | None = None
) -> None:
    body = json.dumps(payload).encode()
    raw_headers = [(b"content-type", b"application/json")]
    raw_headers += [(k.encode("latin-1"), v.encode("latin-1")) for k, v in (headers or {}).items()]
    await send({"type": "http.response.start", "status": status, "headers": raw_headers})
    await send({"type": "http.response.body", "body": body})


class ReceiverServer:
    """uvicorn serving an ASGI app on 127.0.0.1:``port`` inside the current event loop."""

    def __init__(self, app: Any, port: int, *, start_timeout_s: float = 10.0) -> None:
        self.app = app
        self.port = port
        self.start_timeout_s = start_timeout_s
        self._server: uvicorn.Server | None = None
        self._task: asyncio.Task[None] | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/api/agent/events"

    @property
    def running(self) -> bool:
        return self._task is not None

    async def start(self) -> None:
        if self._task is not None:
            return
        config = uvicorn.Config(
            self.app,
            host="127.0.0.1",
            port=self.port,
            lifespan="off",
            access_log=False,
            log_config=None,
            log_level="warning",
            ws="none",
        )
        self._server = uvicorn.Server(config)
        self._task = asyncio.create_task(self._server.serve(), name=f"receiver-{self.port}")
        deadline = time.monotonic() + self.start_timeout_s
        while not self._server.started:
            if self._task.done():
                self._task.result()  # raises the start-up error
                raise RuntimeError(f"receiver on port {self.port} stopped during start-up")
            if time.monotonic() > deadline:
                raise TimeoutError(f"receiver on port {self.port} did not start")
            await asyncio.sleep(0.01)

    async def stop(self) -> None:
        if self._server is None or self._task is None:
            return
        self._server.should_exit = True
        try:
            async with asyncio.timeout(10.0):
                await self._task
        finally:
            self._server = None
            self._task = None

    async def __aenter__(self) -> ReceiverServer:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()
