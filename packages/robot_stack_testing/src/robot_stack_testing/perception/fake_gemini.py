"""A local fake of the Gemini ``generateContent`` REST API that fails like the real one.

Tests and benchmarks point :class:`~robot_mcp_perception.models.gemini_er.GeminiERGrounder`
(the real google-genai SDK) at it. It answers scripted replies, records every request, and
refuses with the real API's HTTP 400 ``INVALID_ARGUMENT`` (403 ``PERMISSION_DENIED`` without
a key) whatever the real service refuses:

- the path ``/v1beta/models/{model}:generateContent`` with a ``POST``;
- an API key (``x-goog-api-key`` header or ``key`` query); a wrong one is ``API_KEY_INVALID``;
- unknown fields anywhere the fake checks (proto JSON accepts camelCase and snake_case names);
- ``contents``: a non-empty list; each content's ``role`` is ``user`` or ``model``; its
  ``parts`` are non-empty; each part carries exactly one data field; ``inlineData`` has a
  supported ``mimeType`` and base64 ``data``;
- ``generationConfig``: known fields only, ``temperature`` in [0, 2], ``topP`` in [0, 1],
  ``candidateCount`` / ``maxOutputTokens`` ≥ 1, ``responseMimeType`` one of the supported
  ones, and ``thinkingConfig`` with known fields only, ``thinkingBudget`` an integer in
  -1..32768 and never together with ``thinkingLevel`` (one of the levels).

An ASGI app; :func:`serve_fake_gemini` runs it with uvicorn on a loopback port.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import json
import re
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qs

import uvicorn

_PATH = re.compile(r"^/v1beta/models/(?P<model>[A-Za-z0-9._-]+):generateContent$")

REQUEST_FIELDS = frozenset(
    {
        "model",
        "contents",
        "tools",
        "toolConfig",
        "safetySettings",
        "systemInstruction",
        "generationConfig",
        "cachedContent",
    }
)
CONTENT_FIELDS = frozenset({"role", "parts"})
PART_DATA_FIELDS = frozenset(
    {
        "text",
        "inlineData",
        "fileData",
        "functionCall",
        "functionResponse",
        "executableCode",
        "codeExecutionResult",
    }
)
PART_META_FIELDS = frozenset({"thought", "thoughtSignature", "videoMetadata", "partMetadata"})
BLOB_FIELDS = frozenset({"mimeType", "data"})
GENERATION_CONFIG_FIELDS = frozenset(
    {
        "stopSequences",
        "responseMimeType",
        "responseSchema",
        "responseJsonSchema",
        "responseModalities",
        "candidateCount",
        "maxOutputTokens",
        "temperature",
        "topP",
        "topK",
        "seed",
        "presencePenalty",
        "frequencyPenalty",
        "responseLogprobs",
        "logprobs",
        "enableEnhancedCivicAnswers",
        "speechConfig",
        "thinkingConfig",
        "mediaResolution",
        "imageConfig",
    }
)
THINKING_FIELDS = frozenset({"includeThoughts", "thinkingBudget", "thinkingLevel"})
THINKING_LEVELS = frozenset(
    {"THINKING_LEVEL_UNSPECIFIED", "MINIMAL", "LOW", "MEDIUM", "HIGH", "XHIGH"}
)
RESPONSE_MIME_TYPES = frozenset({"text/plain", "application/json", "text/x.enum"})
INLINE_MIME_TYPES = frozenset(
    {
        "image/png",
        "image/jpeg",
        "image/webp",
        "image/heic",
        "image/heif",
        "application/pdf",
        "text/plain",
        "audio/wav",
        "audio/mp3",
        "audio/aiff",
        "audio/aac",
        "audio/ogg",
        "audio/flac",
        "video/mp4",
        "video/mpeg",
        "video/mov",
        "video/avi",
        "video/webm",
    }
)
MAX_THINKING_BUDGET = 32_768


class RequestRejectedError(ValueError):
    """What the real API would answer with an error; ``status`` is the HTTP code."""

    def __init__(self, message: str, status: int = 400, reason: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.status = status
        self.reason = reason

    def body(self) -> dict[str, Any]:
        names = {400: "INVALID_ARGUMENT", 403: "PERMISSION_DENIED", 404: "NOT_FOUND"}
        error: dict[str, Any] = {
            "code": self.status,
            "message": self.message,
            "status": names.get(self.status, "INVALID_ARGUMENT"),
        }
        if self.reason:
            error["details"] = [
                {
                    "@type": "type.googleapis.com/google.rpc.ErrorInfo",
                    "reason": self.reason,
                    "domain": "googleapis.com",
                }
            ]
        return {"error": error}


def _camel(name: str) -> str:
    head, *rest = name.split("_")
    return head + "".join(word[:1].upper() + word[1:] for word in rest)


def _fields(obj: Any, allowed: frozenset[str], where: str) -> dict[str, Any]:
    """``obj`` as a dict keyed by camelCase names; unknown names are refused like the API."""
    if not isinstance(obj, dict):
        raise RequestRejectedError(
            f"Invalid value at '{where}': expected an object, got {type(obj).__name__}."
        )
    out: dict[str, Any] = {}
    for key, value in obj.items():
        name = _camel(str(key))
        if name not in allowed:
            raise RequestRejectedError(
                f"Invalid JSON payload received. Unknown name \"{key}\" at '{where}': "
                "Cannot find field."
            )
        if name in out:
            raise RequestRejectedError(f"Invalid JSON payload received. Duplicate field {key!r}.")
        out[name] = value
    return out


def validate_request(path: str, method: str, api_key: str | None, body: bytes, key: str) -> str:
    """Check one request as the real API does; returns the model id or raises."""
    match = _PATH.match(path)
    if match is None:
        raise RequestRejectedError(f"Method not found for path {path}.", status=404)
    if method != "POST":
        raise RequestRejectedError(f"{method} is not allowed on {path}.", status=404)
    if not api_key:
        raise RequestRejectedError(
            "Method doesn't allow unregistered callers (callers without established identity). "
            "Please use API Key or other form of API consumer identity to call this API.",
            status=403,
        )
    if api_key != key:
        raise RequestRejectedError(
            "API key not valid. Please pass a valid API key.", reason="API_KEY_INVALID"
        )
    try:
        payload = json.loads(body or b"null")
    except ValueError as error:
        raise RequestRejectedError(f"Invalid JSON payload received. {error}.") from error
    request = _fields(payload, REQUEST_FIELDS, "")
    _check_contents(request.get("contents"))
    if "systemInstruction" in request:
        _check_content(request["systemInstruction"], "system_instruction", system=True)
    if "generationConfig" in request:
        _check_generation_config(request["generationConfig"])
    return match.group("model")


def _check_contents(contents: Any) -> None:
    if not isinstance(contents, list) or not contents:
        raise RequestRejectedError("* GenerateContentRequest.contents: contents is not specified")
    for index, content in enumerate(contents):
        _check_content(content, f"contents[{index}]")


def _check_content(content: Any, where: str, system: bool = False) -> None:
    fields = _fields(content, CONTENT_FIELDS, where)
    role = fields.get("role")
    if not system and role not in (None, "", "user", "model"):
        raise RequestRejectedError("Please use a valid role: user, model.")
    parts = fields.get("parts")
    if not isinstance(parts, list) or not parts:
        raise RequestRejectedError(
            f"* GenerateContentRequest.{where}.parts: contents.parts must not be empty."
        )
    for index, part in enumerate(parts):
        _check_part(part, f"{where}.parts[{index}]")


def _check_part(part: Any, where: str) -> None:
    fields = _fields(part, PART_DATA_FIELDS | PART_META_FIELDS, where)
    data = [name for name in fields if name in PART_DATA_FIELDS]
    if len(data) != 1:
        raise RequestRejectedError(
            f"* GenerateContentRequest.{where}.data: required oneof field 'data' must have one "
            f"initialized field (got {len(data)})"
        )
    if "text" in fields and not isinstance(fields["text"], str):
        raise RequestRejectedError(f"Invalid value at '{where}.text': expected a string.")
    if "inlineData" in fields:
        _check_blob(fields["inlineData"], f"{where}.inline_data")


def _check_blob(blob: Any, where: str) -> None:
    fields = _fields(blob, BLOB_FIELDS, where)
    mime = fields.get("mimeType")
    if not mime:
        raise RequestRejectedError(f"* GenerateContentRequest.{where}.mime_type: required field")
    if mime not in INLINE_MIME_TYPES:
        raise RequestRejectedError(f"Unsupported MIME type: {mime}")
    data = fields.get("data")
    if not isinstance(data, str) or not data:
        raise RequestRejectedError(f"* GenerateContentRequest.{where}.data: required field")
    try:  # proto JSON bytes: standard or URL-safe base64, padding optional
        raw = data.replace("-", "+").replace("_", "/").rstrip("=")
        base64.b64decode(raw + "=" * (-len(raw) % 4), validate=True)
    except binascii.Error as error:
        raise RequestRejectedError(
            f"Invalid value at '{where}.data' (TYPE_BYTES), Base64 decoding failed"
        ) from error


def _number(value: Any, where: str, low: float, high: float, integer: bool = False) -> None:
    ok = isinstance(value, int if integer else int | float) and not isinstance(value, bool)
    if not ok:
        kind = "TYPE_INT32" if integer else "TYPE_FLOAT"
        raise RequestRejectedError(f"Invalid value at '{where}' ({kind}), {json.dumps(value)}")
    if not low <= value <= high:
        raise RequestRejectedError(
            f"* GenerateContentRequest.{where}: {value} is out of range [{low:g}, {high:g}]"
        )


def _check_generation_config(config: Any) -> None:
    where = "generation_config"
    fields = _fields(config, GENERATION_CONFIG_FIELDS, where)
    if "temperature" in fields:
        _number(fields["temperature"], f"{where}.temperature", 0.0, 2.0)
    if "topP" in fields:
        _number(fields["topP"], f"{where}.top_p", 0.0, 1.0)
    for name, snake in (("candidateCount", "candidate_count"), ("maxOutputTokens", "max_tokens")):
        if name in fields:
            _number(fields[name], f"{where}.{snake}", 1, 2**31 - 1, integer=True)
    mime = fields.get("responseMimeType")
    if mime is not None and mime not in RESPONSE_MIME_TYPES:
        raise RequestRejectedError(
            f"* GenerateContentRequest.{where}.response_mime_type: allowed mimetypes are "
            f"{', '.join(sorted(RESPONSE_MIME_TYPES))}, but got {mime}"
        )
    if "thinkingConfig" in fields:
        _check_thinking(fields["thinkingConfig"], f"{where}.thinking_config")


def _check_thinking(thinking: Any, where: str) -> None:
    fields = _fields(thinking, THINKING_FIELDS, where)
    if "includeThoughts" in fields and not isinstance(fields["includeThoughts"], bool):
        raise RequestRejectedError(f"Invalid value at '{where}.include_thoughts' (TYPE_BOOL)")
    if "thinkingBudget" in fields:
        _number(fields["thinkingBudget"], f"{where}.thinking_budget", -1, MAX_THINKING_BUDGET, True)
    if "thinkingLevel" in fields:
        if fields["thinkingLevel"] not in THINKING_LEVELS:
            raise RequestRejectedError(
                f"Invalid value at '{where}.thinking_level' (type.googleapis.com/"
                f"google.ai.generativelanguage.v1beta.ThinkingConfig.ThinkingLevel), "
                f"{json.dumps(fields['thinkingLevel'])}"
            )
        if "thinkingBudget" in fields:
            raise RequestRejectedError(
                "You can only set only one of thinking budget and thinking level."
            )


UNAVAILABLE = {
    "error": {"code": 503, "message": "The model is overloaded.", "status": "UNAVAILABLE"}
}


def text_reply(text: str) -> dict[str, Any]:
    """A generateContent answer whose only candidate says ``text``."""
    return {
        "candidates": [
            {"content": {"role": "model", "parts": [{"text": text}]}, "finishReason": "STOP"}
        ],
        "usageMetadata": {"promptTokenCount": 1, "candidatesTokenCount": 1, "totalTokenCount": 2},
    }


@dataclass
class FakeGemini:
    """The ASGI app. ``replies``: scripted (status, body) pairs, the last one repeats; a str body
    is the model's text. Rejected requests never consume a scripted reply."""

    api_key: str = "test-key"
    replies: list[tuple[int, Any]] = field(default_factory=lambda: [(200, "[]")])
    requests: list[dict[str, Any]] = field(default_factory=list)
    """Accepted requests: method, path, headers, json."""
    rejected: list[dict[str, Any]] = field(default_factory=list)
    """Refused requests: path, status, message."""
    hang_s: float = 0.0
    fail_every: int = 0
    """When > 0, every n-th accepted request is answered 503 UNAVAILABLE (a flaky service)."""
    base_url: str = ""
    """Set by :func:`serve_fake_gemini`."""
    _lock: threading.Lock = field(default_factory=threading.Lock)

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http":  # pragma: no cover - lifespan is off
            return
        body = b""
        while True:
            message = await receive()
            body += message.get("body", b"")
            if not message.get("more_body"):
                break
        headers = {k.decode().lower(): v.decode() for k, v in scope["headers"]}
        query = parse_qs(scope.get("query_string", b"").decode())
        key = headers.get("x-goog-api-key") or (query.get("key") or [None])[0]
        try:
            model = validate_request(scope["path"], scope["method"], key, body, self.api_key)
        except RequestRejectedError as error:
            with self._lock:
                self.rejected.append(
                    {"path": scope["path"], "status": error.status, "message": error.message}
                )
            await _send_json(send, error.status, error.body())
            return
        with self._lock:
            self.requests.append(
                {
                    "method": scope["method"],
                    "path": scope["path"],
                    "model": model,
                    "headers": headers,
                    "json": json.loads(body),
                    "at": time.monotonic(),
                }
            )
            index = min(len(self.requests) - 1, len(self.replies) - 1)
            status, reply = self.replies[index]
            if self.fail_every and len(self.requests) % self.fail_every == 0:
                status, reply = 503, UNAVAILABLE
        if self.hang_s:
            await asyncio.sleep(self.hang_s)
        await _send_json(send, status, text_reply(reply) if isinstance(reply, str) else reply)


async def _send_json(send: Any, status: int, payload: Any) -> None:
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [(b"content-type", b"application/json")],
        }
    )
    await send({"type": "http.response.body", "body": json.dumps(payload).encode()})


@contextmanager
def serve_fake_gemini(app: FakeGemini, timeout_s: float = 10.0) -> Iterator[str]:
    """Serve ``app`` on a free loopback port; yields its base URL; stops it on exit."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    config = uvicorn.Config(
        app,
        host="127.0.0.1",
        port=port,
        lifespan="off",
        ws="none",
        log_level="warning",
        timeout_graceful_shutdown=1,
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + timeout_s
    try:
        while not server.started:
            if not thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("the fake Gemini server did not start")
            time.sleep(0.01)
        app.base_url = f"http://127.0.0.1:{port}"
        yield app.base_url
    finally:
        server.should_exit = True
        thread.join(timeout=timeout_s)
        sock.close()
