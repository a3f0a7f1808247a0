"""A strict fake of OpenAI's ``POST /v1/audio/transcriptions`` for browser voice tests.

It cannot hear: it answers a fixed transcript. It is strict about the request, rejecting what
the real endpoint rejects (missing/wrong bearer key → 401; not multipart, no ``file``, no
``model``, an unknown model, an unsupported file format or an empty file → 400; a file over
25 MB → 413), with OpenAI's error body shape. Every accepted upload is kept in ``received``.
"""

from __future__ import annotations

import asyncio
import threading
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web

MODELS = frozenset({"whisper-1", "gpt-4o-transcribe", "gpt-4o-mini-transcribe"})
FORMATS = ("flac", "m4a", "mp3", "mp4", "mpeg", "mpga", "oga", "ogg", "wav", "webm")
MAX_BYTES = 25 * 1024 * 1024


@dataclass
class Upload:
    filename: str
    content_type: str
    data: bytes
    model: str


def _error(
    status: int, message: str, code: str | None = None, param: str | None = None
) -> web.Response:
    body = {
        "error": {"message": message, "type": "invalid_request_error", "param": param, "code": code}
    }
    return web.json_response(body, status=status)


@dataclass
class FakeTranscriptionServer:
    """``with FakeTranscriptionServer(port, key, "hello") as server:`` → ``server.base_url``."""

    port: int
    api_key: str
    transcript: str
    received: list[Upload] = field(default_factory=list)
    _loop: asyncio.AbstractEventLoop | None = None
    _runner: web.AppRunner | None = None
    _thread: threading.Thread | None = None

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}/v1"

    async def handle(self, request: web.Request) -> web.Response:
        if request.headers.get("Authorization") != f"Bearer {self.api_key}":
            return _error(401, "Incorrect API key provided.", "invalid_api_key")
        if request.content_length is not None and request.content_length > MAX_BYTES + 65536:
            return _error(413, "Maximum content size limit (26214400) exceeded.")
        if not request.content_type.startswith("multipart/form-data"):
            return _error(400, "Invalid Content-Type header: expected multipart/form-data.")
        form = await request.post()
        upload, model = form.get("file"), form.get("model")
        if not isinstance(upload, web.FileField):
            return _error(400, "you must provide a file", param="file")
        if not isinstance(model, str) or not model:
            return _error(400, "you must provide a model parameter", param="model")
        if model not in MODELS:
            return _error(400, f"invalid model ID: {model}", "model_not_found", "model")
        extension = upload.filename.rsplit(".", 1)[-1].lower() if "." in upload.filename else ""
        if extension not in FORMATS:
            return _error(
                400, f"Invalid file format. Supported formats: {list(FORMATS)}", param="file"
            )
        data = upload.file.read()
        if not data:
            return _error(
                400,
                "The audio file could not be decoded or its format is not supported.",
                param="file",
            )
        if len(data) > MAX_BYTES:
            return _error(413, "Maximum content size limit (26214400) exceeded.")
        self.received.append(Upload(upload.filename, upload.content_type, data, model))
        return web.json_response({"text": self.transcript})

    def __enter__(self) -> FakeTranscriptionServer:
        ready = threading.Event()

        def run() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            app = web.Application(client_max_size=MAX_BYTES * 2)
            app.router.add_post("/v1/audio/transcriptions", self.handle)
            self._runner = web.AppRunner(app, access_log=None)
            loop.run_until_complete(self._runner.setup())
            loop.run_until_complete(web.TCPSite(self._runner, "127.0.0.1", self.port).start())
            ready.set()
            loop.run_forever()
            loop.run_until_complete(self._runner.cleanup())
            loop.close()

        self._thread = threading.Thread(target=run, name="fake-transcription", daemon=True)
        self._thread.start()
        if not ready.wait(10.0):
            raise RuntimeError(f"the fake transcription server did not start on {self.port}")
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._loop.stop)
        if self._thread is not None:
            self._thread.join(timeout=10.0)
