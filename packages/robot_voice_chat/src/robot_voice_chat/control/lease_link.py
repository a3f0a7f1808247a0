"""The brain's end of the lease renewal process (issue 39, ``control.lease_runner: process``).

A busy brain's threads share one interpreter lock: under CPU starvation a renewal thread still
started up to 1.8 s late behind the brain's main thread, while a small separate process was at
most 0.32 s late (benchmarks/supervision_jitter.py). So the renewals can run in a child process
(``python -m robot_voice_chat.control.lease_child``) with its own MCP connections to the motion
servers. The pipe is the child's stdin and stdout, one JSON object a line:

- down (brain → child): first ``init`` (holder, period, TTL, hung bound, the latch, the motion
  servers' configs with their brain credentials: never on the command line or in a log), then
  ``beat`` (the brain's loop runs: every 0.1 s), ``latch`` (at once on change), ``wake``,
  ``reconnect``, ``alarm_taken`` (the brain latched an alarm) and ``stop``;
- up (child → brain): ``ready``/``failed``, ``view`` (a lease's state, renewed at: monotonic
  and wall, what the server said), ``renewed``, ``stat`` (renewal gaps and lateness),
  ``alarms``/``alarm_seen``, ``notice`` (a refused lease) and ``check_now``.

The child exits at once when its stdin reaches EOF (the brain was killed: its leases lapse
within the TTL, so the robot halts as for a dead brain); on shutdown the brain asks it to stop
and ends it by PID if it has not within the timeout. A child that dies under a living brain is
started again (its leases lapse meanwhile: the robot holds itself stopped).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import sys
from collections.abc import Callable
from typing import Any, Protocol

import structlog
from pydantic import SecretStr

from robot_voice_chat.settings import McpServerConfig

logger = structlog.get_logger(__name__)

CHILD_MODULE = "robot_voice_chat.control.lease_child"
RESPAWN_S = 1.0  # a renewal process that died under a living brain is started again after this
LINE_LIMIT = 1 << 20  # one message a line; a view is a few hundred bytes

Message = dict[str, Any]
InitFn = Callable[[], Message]
MessageFn = Callable[[Message], None]


class LeaseLink(Protocol):
    """Where the renewals run when they run in another process (tests: a fake)."""

    @property
    def pid(self) -> int | None: ...

    async def start(self, init: InitFn, on_message: MessageFn) -> None:
        """Start the renewals; ``init()`` is their first message, each message up goes to
        ``on_message`` on the caller's loop (``ready`` first)."""

    def send(self, message: Message) -> None:
        """One message down; never blocks (dropped when the renewals are not running)."""

    async def stop(self, timeout_s: float) -> None:
        """Ask the renewals to stop (they close their connections), then end them."""


def server_payload(config: McpServerConfig) -> Message:
    """A server's config as the child rebuilds it (secrets in clear: for the pipe only)."""
    data = config.model_dump()
    return {k: v.get_secret_value() if isinstance(v, SecretStr) else v for k, v in data.items()}


def _listed(value: object) -> object:
    if isinstance(value, set | frozenset):
        return sorted(value)
    raise TypeError(f"{type(value).__name__} does not go down the lease pipe")


class LeaseProcess:
    """The renewals in a child process (``python -m robot_voice_chat.control.lease_child``)."""

    def __init__(
        self,
        servers: list[McpServerConfig],
        backend: Message,
        *,
        command: list[str] | None = None,
    ) -> None:
        """``servers``: the motion servers (the brain's URLs, transports, credential);
        ``backend``: the child's ``McpToolBackend`` keyword arguments (timeouts)."""
        self.servers = servers
        self.backend = backend
        self.command = command or [sys.executable, "-m", CHILD_MODULE]
        self._process: asyncio.subprocess.Process | None = None
        self._reader: asyncio.Task[None] | None = None
        self._stopping = False
        self._init: InitFn | None = None
        self._on_message: MessageFn | None = None

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process is not None else None

    async def start(self, init: InitFn, on_message: MessageFn) -> None:
        self._init, self._on_message = init, on_message
        await self._spawn()

    async def _spawn(self) -> None:
        assert self._init is not None
        process = await asyncio.create_subprocess_exec(
            *self.command,
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
            stderr=None,  # the child logs (structlog JSON) where the brain does
            limit=LINE_LIMIT,
        )
        self._process = process
        init = {
            "t": "init",
            **self._init(),
            "servers": [server_payload(s) for s in self.servers],
            "backend": self.backend,
        }
        self.send(init)
        self._reader = asyncio.create_task(self._read(process), name="lease-process-reader")
        logger.info("supervision_process_started", pid=process.pid)

    def send(self, message: Message) -> None:
        process = self._process
        if process is None or process.stdin is None or process.stdin.is_closing():
            return
        with contextlib.suppress(ConnectionError, RuntimeError):
            line = json.dumps(message, separators=(",", ":"), default=_listed)
            process.stdin.write(line.encode() + b"\n")

    async def _read(self, process: asyncio.subprocess.Process) -> None:
        assert process.stdout is not None
        assert self._on_message is not None
        while True:
            try:
                line = await process.stdout.readline()
            except (ValueError, asyncio.LimitOverrunError, ConnectionError):
                logger.exception("supervision_process_garbled", pid=process.pid)
                break
            if not line:
                break
            try:
                message = json.loads(line)
            except ValueError:
                logger.warning("supervision_process_garbled", pid=process.pid, line=line[:200])
                continue
            if isinstance(message, dict):
                try:
                    self._on_message(message)
                except Exception:
                    logger.exception("supervision_process_message_failed", kind=message.get("t"))
        code = await process.wait()
        if self._stopping:
            return
        logger.error("supervision_process_exited", pid=process.pid, returncode=code)
        self._on_message({"t": "failed", "detail": f"the renewal process exited ({code})"})
        await asyncio.sleep(RESPAWN_S)
        if not self._stopping:
            await self._spawn()

    async def stop(self, timeout_s: float) -> None:
        self._stopping = True
        process = self._process
        if process is None:
            return
        self.send({"t": "stop"})
        try:
            async with asyncio.timeout(timeout_s):
                await process.wait()
        except TimeoutError:
            logger.warning("supervision_process_not_stopped", pid=process.pid)
            with contextlib.suppress(ProcessLookupError):
                process.kill()  # by its PID: only the child this link started
            await process.wait()
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reader
        logger.info("supervision_process_stopped", pid=process.pid, returncode=process.returncode)
