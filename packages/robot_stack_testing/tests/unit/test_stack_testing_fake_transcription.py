"""The fake transcription server rejects what OpenAI rejects and accepts real uploads."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from robot_stack_testing.fake_transcription import MAX_BYTES, FakeTranscriptionServer

KEY = "test-key"


@pytest.fixture
def server(tcp_port: int) -> Iterator[FakeTranscriptionServer]:
    with FakeTranscriptionServer(tcp_port, KEY, "hello") as running:
        yield running


def post(server: FakeTranscriptionServer, key: str = KEY, **kwargs: Any) -> httpx.Response:
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    return httpx.post(
        f"{server.base_url}/audio/transcriptions", headers=headers, timeout=10, **kwargs
    )


AUDIO = {"file": ("utterance.webm", b"\x1a\x45\xdf\xa3webm-bytes", "audio/webm")}


def test_a_valid_upload_is_transcribed_and_kept(server: FakeTranscriptionServer) -> None:
    response = post(server, files=AUDIO, data={"model": "whisper-1"})
    assert response.status_code == 200
    assert response.json() == {"text": "hello"}
    assert server.received[0].filename == "utterance.webm"
    assert server.received[0].data.startswith(b"\x1a\x45\xdf\xa3")


@pytest.mark.parametrize("key", ["", "wrong-key"])
def test_a_missing_or_wrong_key_is_401(server: FakeTranscriptionServer, key: str) -> None:
    response = post(server, key=key, files=AUDIO, data={"model": "whisper-1"})
    assert response.status_code == 401
    assert response.json()["error"]["code"] == "invalid_api_key"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"json": {"model": "whisper-1"}}, "multipart/form-data"),
        ({"files": {"other": ("a.txt", b"x")}, "data": {"model": "whisper-1"}}, "provide a file"),
        ({"files": AUDIO}, "provide a model"),
        ({"files": AUDIO, "data": {"model": "gpt-4o"}}, "invalid model"),
        (
            {"files": {"file": ("notes.txt", b"x", "text/plain")}, "data": {"model": "whisper-1"}},
            "Invalid file format",
        ),
        (
            {"files": {"file": ("a.webm", b"", "audio/webm")}, "data": {"model": "whisper-1"}},
            "could not be decoded",
        ),
    ],
    ids=["not-multipart", "no-file", "no-model", "unknown-model", "bad-format", "empty-file"],
)
def test_bad_requests_are_400_with_openais_error_shape(
    server: FakeTranscriptionServer, kwargs: dict[str, Any], message: str
) -> None:
    response = post(server, **kwargs)
    assert response.status_code == 400
    error = response.json()["error"]
    assert message in error["message"]
    assert error["type"] == "invalid_request_error"
    assert server.received == []


def test_an_oversized_file_is_413(server: FakeTranscriptionServer) -> None:
    big = {"file": ("a.wav", b"\0" * (MAX_BYTES + 1), "audio/wav")}
    response = post(server, files=big, data={"model": "whisper-1"})
    assert response.status_code == 413
