"""robot-audio-listener over real ROS (issue 36): robot-sim-say speaks on /audio_stamped, the
listener process cuts the utterance and a brain HTTP endpoint on loopback receives it as WAV."""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import wave
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from io import BytesIO
from pathlib import Path

import pytest

from robot_stack_testing import wait_until
from robot_stack_testing.processes import ProcessLauncher

pytestmark = [
    pytest.mark.ros,
    pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed"),
    pytest.mark.skipif(shutil.which("robot-sim-say") is None, reason="robot_sim is not installed"),
]


@pytest.fixture
def brain() -> Iterator[tuple[str, list[tuple[str, bytes]]]]:
    received: list[tuple[str, bytes]] = []

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            return

        def do_POST(self) -> None:
            body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
            received.append((f"{self.path} {self.headers['Content-Type']}", body))
            data = b'{"transcript": "stop", "confidence": 0.9, "mission_id": null}'
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", received
    finally:
        server.shutdown()
        server.server_close()


def test_a_spoken_sentence_reaches_the_brain_as_one_wav(
    brain: tuple[str, list[tuple[str, bytes]]], launcher: ProcessLauncher, tmp_path: Path
) -> None:
    url, received = brain
    listener = launcher.start(
        "audio-listener",
        [sys.executable, "-m", "robot_ros_bridge.audio_listener"],
        env={"BRAIN_URL": url, "AUDIO_LISTENER_READY_FILE": str(tmp_path / "ready")},
    )
    ready = tmp_path / "ready"
    wait_until(lambda: ready.exists() and ready.read_text().strip() == str(listener.pid), 30)
    said = subprocess.run(
        [shutil.which("robot-sim-say") or "robot-sim-say", "go to the kitchen", "--wait-s", "20"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert said.returncode == 0, said.stderr
    wait_until(lambda: received, timeout_s=20, what="the utterance at the brain")
    assert len(received) == 1, listener.log()
    route, wav = received[0]
    assert route == "/api/chat/audio?source=microphone audio/wav"
    with wave.open(BytesIO(wav)) as reader:
        assert (reader.getnchannels(), reader.getframerate()) == (1, 16_000)
        seconds = reader.getnframes() / 16_000
    assert 0.8 < seconds < 3.0  # the sentence (about 1 s), not the room around it
    wait_until(lambda: "utterance_sent" in listener.log(), timeout_s=10)
    assert launcher.stop(listener) == 0
