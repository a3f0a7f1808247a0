"""Audio formats (issue 36): what browsers, phones and other clients send is decoded with PyAV
and resampled to 16 kHz mono; a type it does not read is 415, a body it cannot decode 422,
never a 500. The recordings are made at test time (espeak-ng → PyAV's encoders)."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import numpy as np
import pytest

from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.speech.audio import (
    RATE,
    CorruptAudio,
    UnsupportedAudio,
    decode,
    encode,
    wav_bytes,
)
from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
from robot_voice_chat.services.speech.synth import espeak_available, say
from robot_voice_chat.settings import AppConfig

pytestmark = pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not installed")

# (content type as the client sends it, container, codec)
FORMATS = [
    ("audio/webm;codecs=opus", "webm", "libopus"),  # Chromium and Firefox MediaRecorder
    ("audio/ogg;codecs=opus", "ogg", "libopus"),
    ("audio/mp4", "mp4", "aac"),  # Safari MediaRecorder
    ("audio/wav", "wav", "pcm_s16le"),
]


@pytest.fixture(scope="module")
def speech() -> np.ndarray:
    return say("go to the kitchen")


@pytest.mark.parametrize(("mime", "container", "codec"), FORMATS)
def test_each_format_decodes_to_16khz_mono_of_the_same_length(
    speech: np.ndarray, mime: str, container: str, codec: str
) -> None:
    body = encode(speech, container, codec, rate=16_000 if codec == "pcm_s16le" else 48_000)
    utterance = decode(body, mime)
    assert utterance.pcm.dtype == np.int16
    assert utterance.mime_type == mime.split(";")[0]
    # the same speech: length within the codecs' padding, and not silence
    assert abs(utterance.seconds - speech.size / RATE) < 0.15
    assert np.abs(utterance.pcm.astype(np.int32)).max() > 1000


def test_unsupported_and_corrupt_bodies_are_named() -> None:
    with pytest.raises(UnsupportedAudio, match="not supported"):
        decode(b"whatever", "audio/x-unknown")
    with pytest.raises(CorruptAudio):
        decode(b"RIFF\x00\x00garbage", "audio/wav")
    with pytest.raises(CorruptAudio):
        decode(b"\x1aE\xdf\xa3 not really webm", "audio/webm")
    with pytest.raises(CorruptAudio, match="no audio samples"):
        decode(wav_bytes(np.zeros(0, np.int16)), "audio/wav")


def _container(tmp_path: Path, wake_phrase: str = "") -> Container:
    h = make_harness(tmp_path, FakeLLM([]))
    adapters = Adapters(
        llm=FakeLLM([reply("The kitchen it is.")] * 8),
        planner=FakeLLM([]),
        tools=h.tools,
        speech_output=FakeSpeechOutput(),
        speech_input=FakeSpeechInput("what time is it"),
    )
    config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": str(tmp_path / "traces"), "memory_server": ""},
            "chat": {"wake_phrase": wake_phrase},
        }
    )
    return assemble(config, adapters, FakeEventEmitter())


@pytest.fixture
async def client(tmp_path: Path) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(_container(tmp_path), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        yield c


@pytest.mark.parametrize(("mime", "container", "codec"), FORMATS)
async def test_the_audio_route_answers_like_the_chat_route_for_every_format(
    client: httpx.AsyncClient, speech: np.ndarray, mime: str, container: str, codec: str
) -> None:
    body = encode(speech, container, codec)
    answer = await client.post("/api/chat/audio", content=body, headers={"content-type": mime})
    assert answer.status_code == 200, answer.text
    data = answer.json()
    assert data["transcript"] == "what time is it"
    assert data["reply"] == "The kitchen it is."
    # the fields of POST /api/chat, plus what was heard
    assert {"turn_id", "reply", "route", "mission_id", "transcript", "confidence"} <= set(data)


async def test_the_audio_route_refuses_unsupported_and_corrupt_audio_without_a_500(
    client: httpx.AsyncClient,
) -> None:
    unsupported = await client.post(
        "/api/chat/audio", content=b"abc", headers={"content-type": "audio/x-unknown"}
    )
    assert unsupported.status_code == 415
    assert "not supported" in unsupported.json()["detail"]
    corrupt = await client.post(
        "/api/chat/audio", content=b"RIFF\x10\x00garbage", headers={"content-type": "audio/wav"}
    )
    assert corrupt.status_code == 422
    truncated = encode(say("stop"), "webm", "libopus")[:40]
    cut = await client.post(
        "/api/chat/audio", content=truncated, headers={"content-type": "audio/webm"}
    )
    assert cut.status_code == 422


async def test_the_robots_microphone_needs_the_wake_phrase_and_push_to_talk_does_not(
    tmp_path: Path,
) -> None:
    app = create_app(_container(tmp_path, wake_phrase="robbie"), manage_lifecycle=False)
    body = wav_bytes(say("what time is it"))
    wav = {"content-type": "audio/wav"}
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as client:
        heard = await client.post("/api/chat/audio?source=microphone", content=body, headers=wav)
        pressed = await client.post("/api/chat/audio", content=body, headers=wav)
        unknown = await client.post("/api/chat/audio?source=door", content=body, headers=wav)

    assert heard.status_code == 200, heard.text
    assert heard.json()["addressed"] is False
    assert heard.json()["reply"] == ""  # chatter near the robot is not answered
    assert heard.json()["mission_id"] is None
    assert pressed.json()["addressed"] is True
    assert pressed.json()["reply"] == "The kitchen it is."
    assert unknown.status_code == 422
