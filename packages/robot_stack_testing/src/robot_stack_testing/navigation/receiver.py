"""EventReceiver: a local HTTP endpoint that takes the navigation server's signed TaskEvents and
verifies every HMAC, as the brain does. Runs uvicorn in a daemon thread."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import (
    HEADER_SERVER,
    HEADER_SIGNATURE,
    HEADER_TIMESTAMP,
    SignatureError,
    verify,
)


@dataclass
class EventReceiver:
    url: str
    secret: str
    events: list[TaskEvent] = field(default_factory=list)
    rejected: list[str] = field(default_factory=list)
    arrivals: dict[str, float] = field(default_factory=dict)  # event_id → first time.time()

    def unique(self, task_id: str) -> list[TaskEvent]:
        """The task's events in arrival order, duplicates (same event_id) dropped."""
        seen: set[str] = set()
        out: list[TaskEvent] = []
        for event in list(self.events):
            if event.task_id == task_id and event.event_id not in seen:
                seen.add(event.event_id)
                out.append(event)
        return out

    def types(self, task_id: str) -> list[str]:
        return [e.type for e in self.unique(task_id)]

    def terminal(self, task_id: str) -> TaskEvent | None:
        return next(
            (e for e in self.unique(task_id) if e.type in ("task_done", "task_failed")), None
        )

    def app(self) -> Starlette:
        async def ingest(request: Request) -> JSONResponse:
            body = await request.body()
            try:
                verify(
                    self.secret,
                    request.headers.get(HEADER_TIMESTAMP, ""),
                    body,
                    request.headers.get(HEADER_SIGNATURE, ""),
                )
            except SignatureError as exc:
                self.rejected.append(exc.reason)
                return JSONResponse({"error": exc.reason}, status_code=401)
            event = TaskEvent.model_validate_json(body)
            if request.headers.get(HEADER_SERVER) != event.server:
                self.rejected.append("server_mismatch")
                return JSONResponse({"error": "server_mismatch"}, status_code=401)
            self.arrivals.setdefault(event.event_id, time.time())
            self.events.append(event)
            return JSONResponse({"status": "ok"})

        return Starlette(routes=[Route("/api/agent/events", ingest, methods=["POST"])])


@contextmanager
def running_receiver(
    port: int, secret: str, start_timeout_s: float = 10.0
) -> Iterator[EventReceiver]:
    """An EventReceiver on 127.0.0.1:``port`` for the duration of the block."""
    receiver = EventReceiver(f"http://127.0.0.1:{port}/api/agent/events", secret)
    server = uvicorn.Server(
        uvicorn.Config(receiver.app(), host="127.0.0.1", port=port, log_level="warning")
    )
    thread = threading.Thread(target=server.run, name="event-receiver", daemon=True)
    thread.start()
    deadline = time.monotonic() + start_timeout_s
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.02)  # polls uvicorn's flag, bounded by start_timeout_s
    if not server.started:
        server.should_exit = True
        raise RuntimeError("the event receiver did not start")
    try:
        yield receiver
    finally:
        server.should_exit = True
        thread.join(timeout=10)
