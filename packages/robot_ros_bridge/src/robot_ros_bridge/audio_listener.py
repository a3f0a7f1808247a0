"""``robot-audio-listener``: the robot's own microphone over ROS (issue 36).

A person next to the robot talks to it without a browser. The listener subscribes the
microphone topic in audio_common's ROS 2 messages (``/audio_stamped``: ``AudioDataStamped``,
``/audio_info``: ``AudioInfo`` latched; audio_common 0.3.12, ``interfaces/audio_common_msgs``),
cuts utterances with WebRTC's voice-activity detector (``webrtcvad-wheels``: a GMM shipped
inside the C extension, no model download, no torch) and POSTs each one as a WAV file to the
brain's ``POST /api/chat/audio?source=microphone`` over loopback. The brain recognizes, reads
motion commands back and always acts on "stop" (pipeline/spoken.py); with a site's wake phrase
(``chat.wake_phrase``) it takes a turn only from an utterance that starts with it. The listener
sends every utterance, also while the robot speaks (barge-in, spec 002 §9).

Environment (never argv for the credential):
``BRAIN_URL`` (default ``http://127.0.0.1:8000``), and on a brain with operator login
``AUDIO_LISTENER_USERNAME`` / ``AUDIO_LISTENER_PASSWORD``: the listener logs in at
``/api/auth/login`` and sends the session cookie (logging in again after a 401).
``AUDIO_LISTENER_READY_FILE``: written with the pid once subscribed (the local stack's check).
"""

from __future__ import annotations

import argparse
import http.cookies
import json
import logging
import os
import queue
import sys
import threading
import urllib.error
import urllib.request
import wave
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Any

import structlog
import webrtcvad  # type: ignore[import-untyped]  # no stubs; a C extension

logger = structlog.get_logger("robot_ros_bridge.audio_listener")

AUDIO_TOPIC = "/audio_stamped"
INFO_TOPIC = "/audio_info"
DEFAULT_BRAIN_URL = "http://127.0.0.1:8000"
AUDIO_ROUTE = "/api/chat/audio?source=microphone"  # the brain's wake phrase applies to it
VAD_RATES = (8_000, 16_000, 32_000, 48_000)


@dataclass(frozen=True)
class CutterConfig:
    """How utterances are cut: 30 ms frames; speech starts after ``start_ms`` of voiced frames
    (within the last ``start_window_ms``), ends after ``end_ms`` of unvoiced frames of which
    ``tail_ms`` are kept; ``pre_ms`` before the start is kept (the first syllable's onset); an
    utterance is cut at ``max_s``; one shorter than ``min_ms`` of voice is dropped (a click, a
    door). Short margins matter: the recognizer tries the stop words alone only on a short
    utterance (a bare "stop" is ~0.8 s with these)."""

    aggressiveness: int = 2
    frame_ms: int = 30
    start_ms: int = 90
    start_window_ms: int = 150
    end_ms: int = 600
    tail_ms: int = 150
    pre_ms: int = 200
    max_s: float = 10.0
    min_ms: int = 150


class UtteranceCutter:
    """Voice-activity detection over a stream of S16LE mono PCM; ``feed`` returns the
    utterances that ended in this piece (raw PCM, the same rate)."""

    def __init__(self, rate: int = 16_000, config: CutterConfig | None = None) -> None:
        if rate not in VAD_RATES:
            raise ValueError(f"the VAD works at {VAD_RATES} Hz, not {rate}")
        self.rate = rate
        self.config = config or CutterConfig()
        self._vad = webrtcvad.Vad(self.config.aggressiveness)
        self._frame_bytes = rate * self.config.frame_ms // 1000 * 2
        self._pending = b""
        self._window: deque[tuple[bytes, bool]] = deque(
            maxlen=max(1, self.config.start_window_ms // self.config.frame_ms)
        )
        self._pre: deque[bytes] = deque(maxlen=max(1, self.config.pre_ms // self.config.frame_ms))
        self._speech: list[bytes] | None = None
        self._voiced_frames = 0
        self._silent_frames = 0

    @property
    def in_speech(self) -> bool:
        return self._speech is not None

    def feed(self, pcm: bytes) -> list[bytes]:
        data = self._pending + pcm
        done: list[bytes] = []
        usable = len(data) - len(data) % self._frame_bytes
        for start in range(0, usable, self._frame_bytes):
            utterance = self._frame(data[start : start + self._frame_bytes])
            if utterance is not None:
                done.append(utterance)
        self._pending = data[usable:]
        return done

    def flush(self) -> bytes | None:
        """The utterance in progress (the stream ended), or None."""
        return self._finish() if self._speech is not None else None

    def _frame(self, frame: bytes) -> bytes | None:
        cfg = self.config
        voiced = self._vad.is_speech(frame, self.rate)
        if self._speech is None:
            self._window.append((frame, voiced))
            if sum(v for _, v in self._window) * cfg.frame_ms >= cfg.start_ms:
                self._speech = list(self._pre) + [f for f, _ in self._window]
                self._voiced_frames = sum(v for _, v in self._window)
                self._silent_frames = 0
                self._window.clear()
                self._pre.clear()
            else:
                if len(self._window) == self._window.maxlen:
                    self._pre.append(self._window[0][0])
            return None
        self._speech.append(frame)
        if voiced:
            self._voiced_frames += 1
            self._silent_frames = 0
        else:
            self._silent_frames += 1
        too_long = len(self._speech) * cfg.frame_ms >= cfg.max_s * 1000
        if self._silent_frames * cfg.frame_ms >= cfg.end_ms or too_long:
            return self._finish()
        return None

    def _finish(self) -> bytes | None:
        speech = self._speech or []
        extra = self._silent_frames - self.config.tail_ms // self.config.frame_ms
        if extra > 0:  # the silence that ended it, less the tail kept
            speech = speech[:-extra]
        voiced_ms = self._voiced_frames * self.config.frame_ms
        self._speech = None
        self._voiced_frames = self._silent_frames = 0
        if voiced_ms < self.config.min_ms:
            logger.info("utterance_too_short", voiced_ms=voiced_ms)
            return None
        return b"".join(speech)


def to_wav(pcm: bytes, rate: int) -> bytes:
    """Mono S16LE PCM as a WAV file."""
    out = BytesIO()
    with wave.open(out, "wb") as writer:
        writer.setnchannels(1)
        writer.setsampwidth(2)
        writer.setframerate(rate)
        writer.writeframes(pcm)
    return out.getvalue()


class BrainError(RuntimeError):
    """The brain refused or could not be reached."""


Opener = Callable[[urllib.request.Request, float], Any]


def _urlopen(request: urllib.request.Request, timeout: float) -> Any:
    return urllib.request.urlopen(request, timeout=timeout)  # noqa: S310 - http(s) base URL only


class BrainClient:
    """``POST /api/chat/audio`` with a WAV body; logs in first when credentials are given."""

    def __init__(
        self,
        base_url: str,
        username: str | None = None,
        password: str | None = None,
        *,
        timeout_s: float = 30.0,
        opener: Opener = _urlopen,
    ) -> None:
        if not base_url.startswith(("http://", "https://")):
            raise ValueError(f"BRAIN_URL must be http(s)://…, not {base_url!r}")
        self.base_url = base_url.rstrip("/")
        self._username = username
        self._password = password
        self._timeout_s = timeout_s
        self._open = opener
        self._cookie: str | None = None

    @classmethod
    def from_env(cls, env: Mapping[str, str], base_url: str | None = None) -> BrainClient:
        return cls(
            base_url or env.get("BRAIN_URL", DEFAULT_BRAIN_URL),
            env.get("AUDIO_LISTENER_USERNAME") or None,
            env.get("AUDIO_LISTENER_PASSWORD") or None,
        )

    def send(self, wav: bytes) -> dict[str, Any]:
        """The brain's answer to one utterance (transcript, confidence, reply, mission_id…)."""
        if self._password and self._cookie is None:
            self._login()
        try:
            return self._post_audio(wav)
        except urllib.error.HTTPError as exc:
            if exc.code != 401 or not self._password:
                raise BrainError(f"/api/chat/audio answered {exc.code}") from exc
        self._login()  # the session expired or was revoked: once more with a new one
        try:
            return self._post_audio(wav)
        except urllib.error.HTTPError as exc:
            raise BrainError(f"/api/chat/audio answered {exc.code}") from exc

    def _post_audio(self, wav: bytes) -> dict[str, Any]:
        headers = {"Content-Type": "audio/wav"}
        if self._cookie:
            headers["Cookie"] = self._cookie
        request = urllib.request.Request(  # noqa: S310 - http(s) only, checked in __init__
            f"{self.base_url}{AUDIO_ROUTE}", data=wav, headers=headers, method="POST"
        )
        try:
            with self._open(request, self._timeout_s) as response:
                body = json.loads(response.read() or b"{}")
        except urllib.error.HTTPError:
            raise
        except (urllib.error.URLError, OSError, ValueError) as exc:
            raise BrainError(f"the brain at {self.base_url} is unreachable: {exc}") from exc
        return body if isinstance(body, dict) else {"answer": body}

    def _login(self) -> None:
        payload = json.dumps({"username": self._username or "", "password": self._password})
        request = urllib.request.Request(  # noqa: S310 - http(s) only, checked in __init__
            f"{self.base_url}/api/auth/login",
            data=payload.encode(),
            headers={"Content-Type": "application/json"},
            method="POST",
        )
        try:
            with self._open(request, self._timeout_s) as response:
                cookies = response.headers.get_all("Set-Cookie") or []
        except urllib.error.HTTPError as exc:
            raise BrainError(f"login refused ({exc.code}): check AUDIO_LISTENER_*") from exc
        except (urllib.error.URLError, OSError) as exc:
            raise BrainError(f"the brain at {self.base_url} is unreachable: {exc}") from exc
        jar: http.cookies.SimpleCookie = http.cookies.SimpleCookie()
        for header in cookies:
            jar.load(header)
        if not jar:
            raise BrainError("login answered without a session cookie")
        self._cookie = "; ".join(f"{name}={morsel.value}" for name, morsel in jar.items())


Sender = Callable[[bytes], dict[str, Any]]


class AudioListener:
    """The ROS-free core: audio chunks in, utterances out to ``send`` on a worker thread (the
    ROS callback never waits for the brain). Utterances are sent in order; when the brain is
    slow, at most ``backlog`` wait (the oldest is dropped, logged)."""

    def __init__(
        self, send: Sender, rate: int = 16_000, config: CutterConfig | None = None, backlog: int = 4
    ) -> None:
        self._send = send
        self._config = config
        self._cutter = UtteranceCutter(rate, config)
        self._queue: queue.Queue[bytes | None] = queue.Queue()
        self._backlog = backlog
        self._format_ok = True
        self.sent = 0
        self.failed = 0
        self._worker = threading.Thread(target=self._run, name="audio-sender", daemon=True)
        self._worker.start()

    @property
    def rate(self) -> int:
        return self._cutter.rate

    def on_info(self, channels: int, sample_rate: int, sample_format: str) -> None:
        """The stream's format (AudioInfo): mono S16LE at a VAD rate is taken; else ignored."""
        ok = channels == 1 and sample_format.upper() == "S16LE" and sample_rate in VAD_RATES
        if not ok:
            if self._format_ok:
                logger.error(
                    "audio_format_unsupported",
                    channels=channels,
                    sample_rate=sample_rate,
                    sample_format=sample_format,
                    wanted="mono S16LE at 8/16/32/48 kHz",
                )
            self._format_ok = False
            return
        self._format_ok = True
        if sample_rate != self._cutter.rate:
            logger.info("audio_rate_changed", sample_rate=sample_rate)
            self._cutter = UtteranceCutter(sample_rate, self._config)

    def on_audio(self, pcm: bytes) -> None:
        if not self._format_ok:
            return
        for utterance in self._cutter.feed(pcm):
            self._enqueue(to_wav(utterance, self._cutter.rate))

    def flush(self) -> None:
        utterance = self._cutter.flush()
        if utterance is not None:
            self._enqueue(to_wav(utterance, self._cutter.rate))

    def close(self, timeout_s: float = 5.0) -> None:
        self._queue.put(None)
        self._worker.join(timeout=timeout_s)

    def _enqueue(self, wav: bytes) -> None:
        while self._queue.qsize() >= self._backlog:
            try:
                self._queue.get_nowait()
                logger.warning("utterance_dropped_backlog", backlog=self._backlog)
            except queue.Empty:  # pragma: no cover - the worker took it meanwhile
                break
        self._queue.put(wav)

    def _run(self) -> None:
        while (wav := self._queue.get()) is not None:
            seconds = (len(wav) - 44) / 2 / self._cutter.rate
            try:
                answer = self._send(wav)
            except BrainError as exc:
                self.failed += 1
                logger.error("utterance_not_delivered", error=str(exc), seconds=round(seconds, 2))
                continue
            except Exception:  # one bad answer must not stop the listener
                self.failed += 1
                logger.exception("utterance_send_crashed")
                continue
            self.sent += 1
            logger.info(
                "utterance_sent",
                seconds=round(seconds, 2),
                transcript=answer.get("transcript"),
                confidence=answer.get("confidence"),
                mission_id=answer.get("mission_id"),
            )


def run_node(  # pragma: no cover - exercised by the integration test in a child process
    listener: AudioListener,
    topic: str,
    stop: threading.Event,
    on_ready: Callable[[], None] | None = None,
) -> None:
    import rclpy
    from audio_common_msgs.msg import AudioDataStamped, AudioInfo
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("robot_audio_listener", context=context)
    latched = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
    )

    def on_info(message: AudioInfo) -> None:
        listener.on_info(message.channels, message.sample_rate, message.sample_format)

    def on_audio(message: AudioDataStamped) -> None:
        listener.on_audio(bytes(message.audio.data))

    node.create_subscription(AudioInfo, INFO_TOPIC, on_info, latched)
    node.create_subscription(AudioDataStamped, topic, on_audio, 100)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    logger.info("audio_listener_started", topic=topic, info_topic=INFO_TOPIC)
    if on_ready is not None:
        on_ready()
    try:
        while not stop.is_set() and context.ok():
            executor.spin_once(timeout_sec=0.2)
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def _configure_logging(level: str) -> None:  # pragma: no cover - process setup
    logging.basicConfig(level=level, stream=sys.stderr, format="%(message)s")
    structlog.configure(
        processors=[
            structlog.contextvars.merge_contextvars,
            structlog.processors.add_log_level,
            structlog.processors.TimeStamper(fmt="iso", utc=True),
            structlog.processors.EventRenamer("event"),
            structlog.processors.JSONRenderer(),
        ],
        wrapper_class=structlog.make_filtering_bound_logger(logging.getLevelName(level)),
        logger_factory=structlog.PrintLoggerFactory(file=sys.stderr),
    )


def main(argv: Sequence[str] | None = None) -> int:  # pragma: no cover - the process entry
    import signal

    parser = argparse.ArgumentParser(
        prog="robot-audio-listener", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--topic", default=AUDIO_TOPIC, help="AudioDataStamped topic")
    parser.add_argument("--brain-url", default=None, help="default: $BRAIN_URL or :8000")
    parser.add_argument("--aggressiveness", type=int, default=2, choices=range(4))
    parser.add_argument("--end-ms", type=int, default=600, help="silence that ends an utterance")
    parser.add_argument("--log-level", default=os.environ.get("LOG_LEVEL", "INFO"))
    args = parser.parse_args(argv)
    _configure_logging(args.log_level.upper())
    try:
        client = BrainClient.from_env(os.environ, args.brain_url)
    except ValueError as exc:
        sys.stderr.write(f"robot-audio-listener: {exc}\n")
        return 2
    config = CutterConfig(aggressiveness=args.aggressiveness, end_ms=args.end_ms)
    listener = AudioListener(client.send, config=config)
    stop = threading.Event()
    ready_file = os.environ.get("AUDIO_LISTENER_READY_FILE")

    def ready() -> None:
        if ready_file:  # the local stack's readiness check: our pid once subscribed
            Path(ready_file).write_text(f"{os.getpid()}\n")

    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    try:
        run_node(listener, args.topic, stop, ready)
    finally:
        listener.flush()
        listener.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
