"""Speech on the robot's own speaker through a local TTS engine (Debian's espeak-ng).

One worker speaks queued sentences one at a time (argv list, never a shell); ``interrupt``
drops the queue and terminates the sentence being spoken.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil

import structlog

from robot_voice_chat.services.speech.base import SpeechOutput

logger = structlog.get_logger(__name__)


class EspeakSpeechOutput(SpeechOutput):
    def __init__(self, command: list[str], sentence_timeout_s: float = 30.0) -> None:
        if not command or shutil.which(command[0]) is None:
            raise ValueError(
                f"TTS engine {command[:1]} not found; install it (apt install espeak-ng) "
                "or select speech_output=socketio"
            )
        self._command = list(command)
        self._timeout_s = sentence_timeout_s
        self._queue: asyncio.Queue[str] = asyncio.Queue()
        self._worker: asyncio.Task[None] | None = None
        self._current: asyncio.subprocess.Process | None = None
        self.spoken: list[str] = []

    async def speak_sentence(self, sentence: str) -> None:
        if self._worker is None or self._worker.done():
            self._worker = asyncio.create_task(self._run())
        self._queue.put_nowait(sentence)

    async def interrupt(self) -> None:
        while not self._queue.empty():
            self._queue.get_nowait()
        process = self._current
        if process is not None and process.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                process.terminate()

    async def drain(self, timeout_s: float) -> None:
        """Wait until everything queued has been spoken (tests, shutdown)."""
        async with asyncio.timeout(timeout_s):
            while not self._queue.empty() or self._current is not None:  # noqa: ASYNC110
                await asyncio.sleep(0.01)

    async def _run(self) -> None:
        while True:
            sentence = await self._queue.get()
            try:
                self._current = await asyncio.create_subprocess_exec(
                    *self._command,
                    sentence,
                    stdout=asyncio.subprocess.DEVNULL,
                    stderr=asyncio.subprocess.DEVNULL,
                )
                try:
                    async with asyncio.timeout(self._timeout_s):
                        await self._current.wait()
                except TimeoutError:
                    self._current.kill()
                    await self._current.wait()
                if self._current.returncode == 0:
                    self.spoken.append(sentence)
            except OSError as exc:
                logger.warning("tts_failed", error=str(exc))
            finally:
                self._current = None

    async def aclose(self) -> None:
        await self.interrupt()
        if self._worker is not None:
            self._worker.cancel()
            await asyncio.wait({self._worker}, timeout=2.0)
