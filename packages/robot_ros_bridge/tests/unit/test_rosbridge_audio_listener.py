"""robot-audio-listener's core (issue 36): utterances cut by the VAD from espeak-ng speech made
at test time, sent in order as WAV, and the brain client (login, cookie, 401, unreachable)
against a real HTTP server on loopback."""

from __future__ import annotations

import json
import shutil
import subprocess
import threading
import wave
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from io import BytesIO
from typing import Any

import numpy as np
import pytest

from robot_ros_bridge.audio_listener import (
    AudioListener,
    BrainClient,
    BrainError,
    CutterConfig,
    UtteranceCutter,
    to_wav,
)
from robot_stack_testing import wait_until

RATE = 16_000
needs_espeak = pytest.mark.skipif(
    shutil.which("espeak-ng") is None, reason="espeak-ng is not installed"
)


def speech(text: str, voice: str = "en-us") -> np.ndarray:
    wav = subprocess.run(
        ["espeak-ng", "-v", voice, "--stdout", text],
        capture_output=True,
        check=True,
        timeout=30,
    ).stdout
    with wave.open(BytesIO(wav)) as reader:
        rate = reader.getframerate()
        samples = np.frombuffer(reader.readframes(reader.getnframes()), dtype="<i2")
    times = np.arange(int(samples.size * RATE / rate)) / RATE
    return np.interp(times, np.arange(samples.size) / rate, samples.astype(np.float64))


def room(*parts: np.ndarray | float, noise: float = 30.0, seed: int = 1) -> bytes:
    """Speech parts and silences (seconds) in a room with a little noise, as S16LE bytes."""
    pieces = [np.zeros(int(p * RATE)) if isinstance(p, float) else p for p in parts]
    signal = np.concatenate(pieces)
    signal = signal + np.random.default_rng(seed).standard_normal(signal.size) * noise
    return np.clip(signal, -32768, 32767).astype("<i2").tobytes()


def voiced_seconds(pcm: np.ndarray) -> float:
    loud = np.flatnonzero(np.abs(pcm) > 0.05 * np.abs(pcm).max())
    return float(loud[-1] - loud[0]) / RATE


def feed_in_chunks(cutter: UtteranceCutter, pcm: bytes, size: int) -> list[bytes]:
    out: list[bytes] = []
    for start in range(0, len(pcm), size):
        out += cutter.feed(pcm[start : start + size])
    return out


@needs_espeak
def test_two_sentences_are_cut_apart_and_silence_is_not_sent() -> None:
    first, second = speech("go to the kitchen"), speech("stop", "en-gb-scotland")
    pcm = room(1.0, first, 1.5, second, 1.5)
    cutter = UtteranceCutter(RATE)
    utterances = feed_in_chunks(cutter, pcm, 3200)  # 100 ms chunks, as robot-sim-say sends
    assert len(utterances) == 2
    for utterance, spoken in zip(utterances, (first, second), strict=True):
        seconds = len(utterance) / 2 / RATE
        # the whole sentence, with at most the pre-roll and the end silence around it
        assert voiced_seconds(spoken) <= seconds <= voiced_seconds(spoken) + 1.2
    assert cutter.flush() is None


@needs_espeak
def test_chunk_sizes_do_not_change_the_cut() -> None:
    pcm = room(0.5, speech("fetch the package from the mailroom"), 1.0)
    whole = UtteranceCutter(RATE).feed(pcm)
    odd = feed_in_chunks(UtteranceCutter(RATE), pcm, 1234)
    assert len(whole) == 1
    assert odd == whole


def test_room_noise_alone_is_no_utterance() -> None:
    cutter = UtteranceCutter(RATE)
    assert cutter.feed(room(4.0)) == []
    assert not cutter.in_speech
    assert cutter.flush() is None


def test_a_click_shorter_than_min_voice_is_dropped() -> None:
    tone = np.sin(np.arange(int(0.05 * RATE)) * 2 * np.pi * 300 / RATE) * 12000
    cutter = UtteranceCutter(RATE, CutterConfig(min_ms=300))
    assert cutter.feed(room(0.5, tone, 1.0)) == []


@needs_espeak
def test_speech_still_going_on_is_cut_at_max_and_flushed_at_the_end() -> None:
    long = speech("go to the kitchen then go to the mailroom then go to reception and back")
    cutter = UtteranceCutter(RATE, CutterConfig(max_s=1.5))
    pieces = cutter.feed(room(0.3, long))
    assert pieces
    assert all(len(p) / 2 / RATE <= 1.5 + 0.03 for p in pieces)
    tail = UtteranceCutter(RATE)
    assert tail.feed(room(0.3, speech("go to the kitchen"))) == []
    assert tail.in_speech
    rest = tail.flush()
    assert rest is not None
    assert len(rest) > RATE  # the sentence, not nothing


def test_rates_the_vad_does_not_know_are_refused() -> None:
    with pytest.raises(ValueError, match="22050"):
        UtteranceCutter(22050)


def test_wav_is_mono_s16le_at_the_rate() -> None:
    pcm = room(0.2)
    with wave.open(BytesIO(to_wav(pcm, RATE))) as reader:
        assert (reader.getnchannels(), reader.getsampwidth(), reader.getframerate()) == (1, 2, RATE)
        assert reader.readframes(reader.getnframes()) == pcm


class Recorder:
    def __init__(self, fail: list[Exception] | None = None) -> None:
        self.wavs: list[bytes] = []
        self.fail = fail or []

    def __call__(self, wav: bytes) -> dict[str, Any]:
        if self.fail:
            raise self.fail.pop(0)
        self.wavs.append(wav)
        return {"transcript": "stop", "confidence": 0.9, "mission_id": None}


@needs_espeak
def test_listener_sends_each_utterance_as_wav_in_order() -> None:
    recorder = Recorder(fail=[BrainError("down"), RuntimeError("bad answer")])
    listener = AudioListener(recorder)
    try:
        listener.on_info(1, RATE, "S16LE")
        words = ["stop", "go to the kitchen", "fetch the package from the mailroom", "yes"]
        parts: list[np.ndarray | float] = [0.5]
        for word in words:
            parts += [speech(word), 1.2]
        listener.on_audio(room(*parts))
        wait_until(lambda: listener.sent + listener.failed == 4, timeout_s=10)
    finally:
        listener.close()
    assert listener.failed == 2  # the brain down, then a bad answer: the listener goes on
    assert len(recorder.wavs) == 2
    durations = []
    for wav in recorder.wavs:
        with wave.open(BytesIO(wav)) as reader:
            assert reader.getframerate() == RATE
            durations.append(reader.getnframes() / RATE)
    assert durations[0] > durations[1]  # the fetch request, then "yes": in order


@needs_espeak
def test_unsupported_formats_are_ignored_and_a_new_rate_is_followed() -> None:
    recorder = Recorder()
    listener = AudioListener(recorder)
    try:
        listener.on_info(2, RATE, "S16LE")  # stereo: not understood, nothing is sent
        listener.on_audio(room(0.3, speech("stop"), 1.0))
        listener.on_info(1, 44_100, "S16LE")
        listener.on_audio(room(0.3, speech("stop"), 1.0))
        listener.on_info(1, 8_000, "s16le")
        assert listener.rate == 8_000
        eight = speech("go to the kitchen")[::2]  # 16 kHz -> 8 kHz
        listener.on_audio(
            np.concatenate([np.zeros(4000), eight, np.zeros(4000)]).astype("<i2").tobytes()
        )
        listener.flush()
        wait_until(lambda: listener.sent == 1, timeout_s=10)
    finally:
        listener.close()
    with wave.open(BytesIO(recorder.wavs[0])) as reader:
        assert reader.getframerate() == 8_000


def test_a_slow_brain_keeps_only_the_newest_backlog() -> None:
    release = threading.Event()
    got: list[bytes] = []

    def slow(wav: bytes) -> dict[str, Any]:
        release.wait(10)
        got.append(wav)
        return {}

    listener = AudioListener(slow, backlog=2)
    try:
        for n in range(6):
            listener._enqueue(bytes([n]) * 50)
        release.set()
        wait_until(lambda: got and got[-1] == bytes([5]) * 50, timeout_s=10)
    finally:
        listener.close()
    assert len(got) <= 3  # one in the brain's hands, then the newest two


class FakeBrain:
    """``/api/auth/login`` and ``/api/chat/audio`` as the brain answers them."""

    def __init__(self, password: str | None = None) -> None:
        self.password = password
        self.sessions: set[str] = set()
        self.audio: list[tuple[str, bytes]] = []
        self.logins = 0
        brain = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: object) -> None:
                return

            def do_POST(self) -> None:
                body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
                if self.path == "/api/auth/login":
                    brain.logins += 1
                    sent = json.loads(body)
                    if sent["password"] != brain.password:
                        return self._answer(401, {"detail": "wrong username or password"})
                    token = f"t{brain.logins}"
                    brain.sessions.add(token)
                    return self._answer(
                        200,
                        {"operator": "op"},
                        {"Set-Cookie": f"rvc_session={token}; HttpOnly; Path=/"},
                    )
                cookie = self.headers.get("Cookie", "")
                if brain.password and cookie.removeprefix("rvc_session=") not in brain.sessions:
                    return self._answer(401, {"detail": "login required"})
                brain.audio.append((self.headers["Content-Type"], body))
                return self._answer(200, {"transcript": "stop", "confidence": 0.8})

            def _answer(
                self, status: int, body: dict[str, Any], headers: dict[str, str] | None = None
            ) -> None:
                data = json.dumps(body).encode()
                self.send_response(status)
                for key, value in (headers or {}).items():
                    self.send_header(key, value)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)


@pytest.fixture
def brain(request: pytest.FixtureRequest) -> Iterator[FakeBrain]:
    fake = FakeBrain(getattr(request, "param", None))
    fake.thread.start()
    try:
        yield fake
    finally:
        fake.server.shutdown()
        fake.server.server_close()


def test_client_posts_the_wav_without_login_on_an_open_brain(brain: FakeBrain) -> None:
    client = BrainClient.from_env({"BRAIN_URL": brain.url})
    answer = client.send(to_wav(b"\0\0" * 160, RATE))
    assert answer == {"transcript": "stop", "confidence": 0.8}
    assert brain.logins == 0
    assert brain.audio[0][0] == "audio/wav"
    assert brain.audio[0][1].startswith(b"RIFF")


@pytest.mark.parametrize("brain", ["s3cret"], indirect=True)
def test_client_logs_in_and_logs_in_again_when_the_session_is_gone(brain: FakeBrain) -> None:
    env = {
        "BRAIN_URL": brain.url,
        "AUDIO_LISTENER_USERNAME": "op",
        "AUDIO_LISTENER_PASSWORD": "s3cret",
    }
    client = BrainClient.from_env(env)
    client.send(b"RIFF1")
    assert brain.logins == 1
    brain.sessions.clear()  # revoked (logout, a new password, a restart)
    client.send(b"RIFF2")
    assert brain.logins == 2
    assert [body for _, body in brain.audio] == [b"RIFF1", b"RIFF2"]


@pytest.mark.parametrize("brain", ["s3cret"], indirect=True)
def test_client_errors_are_brain_errors(brain: FakeBrain) -> None:
    wrong = BrainClient(brain.url, "op", "wrong")
    with pytest.raises(BrainError, match="login refused"):
        wrong.send(b"RIFF")
    anonymous = BrainClient(brain.url)
    with pytest.raises(BrainError, match="401"):
        anonymous.send(b"RIFF")
    assert brain.audio == []


def test_client_unreachable_and_bad_urls() -> None:
    with pytest.raises(ValueError, match="http"):
        BrainClient("file:///etc/passwd")
    closed = ThreadingHTTPServer(("127.0.0.1", 0), BaseHTTPRequestHandler)
    url = f"http://127.0.0.1:{closed.server_address[1]}"
    closed.server_close()
    with pytest.raises(BrainError, match="unreachable"):
        BrainClient(url).send(b"RIFF")
    with pytest.raises(BrainError, match="unreachable"):
        BrainClient(url, "op", "pw").send(b"RIFF")
