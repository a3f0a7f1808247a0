"""The supervisor's runners for unit tests: ``make_supervisor`` builds one whose renewals run on
a thread or in the renewal process, faked by ``PipeOnThread``: the child's own code
(``ChildRenewer``) on a thread with its own event loop, every message both ways through JSON
as on the pipe."""

from __future__ import annotations

import asyncio
import json
import threading
from collections.abc import Callable
from typing import Any

import pytest

from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.lease_child import ChildRenewer, MirrorLatch
from robot_voice_chat.control.lease_link import InitFn, Message, MessageFn
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.tools.base import ToolBackend


class PipeOnThread:
    """Implements ``LeaseLink``: the renewal process's code, run on a thread named
    ``supervision`` (as the thread runner's), messages JSON-encoded both ways."""

    pid = None

    def __init__(self, tools: Callable[[], ToolBackend]) -> None:
        self.tools = tools
        self.up: list[Message] = []  # every message the child sent (recorded on its thread)
        self.down: list[Message] = []
        self.init: Message = {}
        self.renewer: ChildRenewer | None = None
        self._lock = threading.Lock()
        self._pending: list[str] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._brain: asyncio.AbstractEventLoop | None = None
        self._on_message: MessageFn | None = None
        self._thread: threading.Thread | None = None
        self._done: asyncio.Event | None = None

    async def start(self, init: InitFn, on_message: MessageFn) -> None:
        self._brain, self._on_message = asyncio.get_running_loop(), on_message
        self.init = json.loads(json.dumps({"t": "init", **init()}))
        self._thread = threading.Thread(target=self._main, name="supervision", daemon=True)
        self._thread.start()

    def send(self, message: Message) -> None:
        line = json.dumps(message)
        with self._lock:
            self.down.append(json.loads(line))
            loop = self._loop
            if loop is None:
                self._pending.append(line)
                return
        loop.call_soon_threadsafe(self._handle, line)

    async def stop(self, timeout_s: float) -> None:
        self.send({"t": "stop"})
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, timeout_s)

    def sent_up(self, kind: str) -> list[Message]:
        with self._lock:
            return [m for m in self.up if m.get("t") == kind]

    # --- the child's side ---------------------------------------------------------------
    def _up(self, message: Message) -> None:
        line = json.dumps(message)
        with self._lock:
            self.up.append(json.loads(line))
        assert self._brain is not None
        self._brain.call_soon_threadsafe(self._deliver, line)

    def _deliver(self, line: str) -> None:
        assert self._on_message is not None
        self._on_message(json.loads(line))

    def _handle(self, line: str) -> None:
        message = json.loads(line)
        assert self.renewer is not None
        self.renewer.handle(message)
        if message["t"] == "stop" and self._done is not None:
            self._done.set()

    def _main(self) -> None:
        asyncio.run(self._serve())

    async def _serve(self) -> None:
        init = self.init
        latch = MirrorLatch()
        latch.mirror(init["latched"], init["reason"])
        self.renewer = ChildRenewer(
            self.tools(),
            latch,
            self._up,
            period_s=init["period_s"],
            ttl_s=init["ttl_s"],
            holder=init["holder"],
            hung_after_s=init["hung_after_s"],
        )
        self._done = asyncio.Event()
        await self.renewer.run()
        with self._lock:
            self._loop = asyncio.get_running_loop()
            pending, self._pending = self._pending, []
        for line in pending:
            self._handle(line)
        await self._done.wait()
        await self.renewer.finish()


def supervisor_for(
    runner: str,
    brain: ToolBackend,
    lease: Callable[[], ToolBackend],
    latch: SafetyLatch,
    **kwargs: Any,
) -> MotionSupervisor:
    """A supervisor whose renewals run on a thread or in the (fake) renewal process."""
    if runner == "thread":
        return MotionSupervisor(brain, latch, lease_tools=lease, **kwargs)
    return MotionSupervisor(brain, latch, lease_process=PipeOnThread(lease), **kwargs)


@pytest.fixture
def make_supervisor() -> Callable[..., MotionSupervisor]:
    return supervisor_for
