"""A local OpenAI-compatible API (chat completions + audio transcriptions) that rejects what
the real one rejects.

``POST /v1/chat/completions`` checks ``model`` and ``messages`` present, roles known, content
present (null only on an assistant turn with tool calls), function names matching
``^[a-zA-Z0-9_-]{1,64}$`` (tools and assistant tool calls), every assistant ``tool_calls``
answered by ``tool`` messages with those ``tool_call_id``\\s before the next turn, and no
``tool`` message without a preceding call. ``POST /v1/audio/transcriptions`` checks the
multipart shape (``file`` with a supported extension, ``model``). Rejections are 400s in the
API's shape ``{"error": {"message", "type", "param", "code"}}``.

A ``responder`` gets the request body and returns ``{"content": str | None, "tool_calls":
[{"name", "arguments": {...}}]}``; streaming (``stream: true``) is served as SSE chunks.
``null_content=False`` answers like Ollama's OpenAI-compatible endpoint, which also rejects an
assistant turn's ``content: null`` (400 "invalid message content type: <nil>").
"""

from __future__ import annotations

import itertools
import json
import math
import re
import threading
import time
from collections.abc import Callable
from typing import Any

from aiohttp import BodyPartReader, web

NAME = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")
ROLES = ("system", "developer", "user", "assistant", "tool", "function")
AUDIO_FORMATS = ("flac", "m4a", "mp3", "mp4", "mpeg", "mpga", "oga", "ogg", "wav", "webm")
ChatResponder = Callable[[dict[str, Any]], dict[str, Any]]
Transcriber = Callable[[bytes, str], str]


class Invalid(Exception):
    def __init__(self, message: str, param: str | None = None, code: str | None = None) -> None:
        super().__init__(message)
        self.message, self.param, self.code = message, param, code


def _check_name(name: Any, param: str) -> None:
    if not isinstance(name, str) or not NAME.match(name):
        raise Invalid(
            f"Invalid '{param}': string does not match pattern. Expected a string that "
            "matches the pattern '^[a-zA-Z0-9_-]{1,64}$'.",
            param,
            "invalid_value",
        )


def _check_message(i: int, m: Any, null_content: bool = True) -> None:
    if not isinstance(m, dict) or m.get("role") not in ROLES:
        role = m.get("role") if isinstance(m, dict) else m
        raise Invalid(
            f"Invalid value: '{role}'. Supported values are: 'system', 'assistant', 'user', "
            "'function', 'tool', and 'developer'.",
            f"messages[{i}].role",
            "invalid_value",
        )
    calls = m.get("tool_calls") or []
    if m.get("content") is None and not null_content:
        raise Invalid("invalid message content type: <nil>")
    if m.get("content") is None and not (m["role"] == "assistant" and calls):
        raise Invalid(
            "Invalid value for 'content': expected a string, got null.",
            f"messages.[{i}].content",
        )
    for j, call in enumerate(calls):
        _check_name(
            (call.get("function") or {}).get("name"), f"messages[{i}].tool_calls[{j}].function.name"
        )
    if m["role"] == "tool" and not m.get("tool_call_id"):
        raise Invalid("Missing parameter 'tool_call_id'.", f"messages[{i}].tool_call_id")


def _check_pairing(messages: list[dict[str, Any]]) -> None:
    open_ids: list[str] = []
    for i, m in enumerate(messages):
        if m["role"] == "tool":
            if m.get("tool_call_id") not in open_ids:
                raise Invalid(
                    "Invalid parameter: messages with role 'tool' must be a response to a "
                    "preceeding message with 'tool_calls'.",
                    f"messages.[{i}].role",
                )
            open_ids.remove(m["tool_call_id"])
            continue
        if open_ids:
            raise Invalid(
                "An assistant message with 'tool_calls' must be followed by tool messages "
                "responding to each 'tool_call_id'. The following tool_call_ids did not have "
                f"response messages: {', '.join(open_ids)}",
                "messages",
            )
        open_ids = [str(c.get("id")) for c in m.get("tool_calls") or []]
    if open_ids:
        raise Invalid(
            "An assistant message with 'tool_calls' must be followed by tool messages "
            "responding to each 'tool_call_id'. The following tool_call_ids did not have "
            f"response messages: {', '.join(open_ids)}",
            "messages",
        )


def validate_chat(body: dict[str, Any], null_content: bool = True) -> None:
    """Raise :class:`Invalid` for the first rule the request breaks."""
    if not isinstance(body.get("model"), str) or not body["model"]:
        raise Invalid("you must provide a model parameter", "model")
    messages = body.get("messages")
    if not isinstance(messages, list) or not messages:
        raise Invalid("'messages' is a required property and must not be empty", "messages")
    if "max_tokens" in body and (not isinstance(body["max_tokens"], int) or body["max_tokens"] < 1):
        raise Invalid("Invalid 'max_tokens': integer below minimum value.", "max_tokens")
    for i, tool in enumerate(body.get("tools") or []):
        _check_name((tool.get("function") or {}).get("name"), f"tools[{i}].function.name")
    for i, m in enumerate(messages):
        _check_message(i, m, null_content)
    _check_pairing(messages)


def error_response(status: int, exc: Invalid) -> web.Response:
    body = {
        "error": {
            "message": exc.message,
            "type": "invalid_request_error",
            "param": exc.param,
            "code": exc.code,
        }
    }
    return web.json_response(body, status=status)


def tokens(value: Any) -> int:
    return math.ceil(len(json.dumps(value, separators=(",", ":"))) / 4) if value else 0


class FakeOpenAIApi:
    """Chat completions + transcriptions on loopback; ``app()`` for :func:`serve_in_thread`."""

    def __init__(
        self,
        responder: ChatResponder,
        transcriber: Transcriber | None = None,
        null_content: bool = True,
    ) -> None:
        self.responder = responder
        self.null_content = null_content
        self.transcriber = transcriber or (lambda audio, name: "hello robot")
        self.requests: list[dict[str, Any]] = []
        self.transcriptions: list[dict[str, Any]] = []
        self.rejections: list[str] = []
        self.fail_status: int | None = None
        self._ids = itertools.count(1)
        self._lock = threading.Lock()

    def app(self) -> web.Application:
        app = web.Application()
        app.router.add_post("/v1/chat/completions", self._chat)
        app.router.add_post("/v1/audio/transcriptions", self._transcribe)
        return app

    def _reject(self, status: int, exc: Invalid) -> web.Response:
        self.rejections.append(exc.message)
        return error_response(status, exc)

    def _authorized(self, request: web.Request) -> bool:
        return request.headers.get("Authorization", "").startswith("Bearer ") and len(
            request.headers["Authorization"]
        ) > len("Bearer ")

    async def _chat(self, request: web.Request) -> web.StreamResponse:
        if not self._authorized(request):
            return self._reject(401, Invalid("Incorrect API key provided", None, "invalid_api_key"))
        try:
            body = await request.json()
            validate_chat(body, self.null_content)
        except ValueError:
            return self._reject(400, Invalid("We could not parse the JSON body of your request."))
        except Invalid as exc:
            return self._reject(400, exc)
        if self.fail_status is not None:
            return error_response(self.fail_status, Invalid("fake outage", None, "server_error"))
        with self._lock:
            self.requests.append(body)
            n = next(self._ids)
            answer = self.responder(body)
        calls = [
            {
                "id": f"call_fake_{n}_{k}",
                "type": "function",
                "function": {"name": c["name"], "arguments": json.dumps(c.get("arguments", {}))},
            }
            for k, c in enumerate(answer.get("tool_calls") or [])
        ]
        content = answer.get("content")
        finish = "tool_calls" if calls else "stop"
        if body.get("stream"):
            return await self._stream(request, body["model"], n, content, calls, finish)
        message: dict[str, Any] = {"role": "assistant", "content": content}
        if calls:
            message["tool_calls"] = calls
        return web.json_response(
            {
                "id": f"chatcmpl-fake-{n}",
                "object": "chat.completion",
                "created": int(time.time()),
                "model": body["model"],
                "choices": [{"index": 0, "message": message, "finish_reason": finish}],
                "usage": {
                    "prompt_tokens": tokens(body["messages"]),
                    "completion_tokens": tokens(message),
                    "total_tokens": tokens(body["messages"]) + tokens(message),
                },
            }
        )

    async def _stream(
        self,
        request: web.Request,
        model: str,
        n: int,
        content: str | None,
        calls: list[dict[str, Any]],
        finish: str,
    ) -> web.StreamResponse:
        response = web.StreamResponse(headers={"Content-Type": "text/event-stream"})
        await response.prepare(request)

        def chunk(delta: dict[str, Any], finish_reason: str | None = None) -> bytes:
            data = {
                "id": f"chatcmpl-fake-{n}",
                "object": "chat.completion.chunk",
                "created": int(time.time()),
                "model": model,
                "choices": [{"index": 0, "delta": delta, "finish_reason": finish_reason}],
            }
            return f"data: {json.dumps(data)}\n\n".encode()

        await response.write(chunk({"role": "assistant", "content": ""}))
        for word in re.findall(r"\S+\s*", content or ""):
            await response.write(chunk({"content": word}))
        for index, call in enumerate(calls):
            await response.write(chunk({"tool_calls": [{"index": index, **call}]}))
        await response.write(chunk({}, finish))
        await response.write(b"data: [DONE]\n\n")
        await response.write_eof()
        return response

    async def _transcribe(self, request: web.Request) -> web.Response:
        if not self._authorized(request):
            return self._reject(401, Invalid("Incorrect API key provided", None, "invalid_api_key"))
        if not request.content_type.startswith("multipart/form-data"):
            return self._reject(
                400, Invalid("Content-Type must be multipart/form-data", None, "invalid_value")
            )
        fields: dict[str, Any] = {}
        reader = await request.multipart()
        while True:
            part = await reader.next()
            if part is None:
                break
            if isinstance(part, BodyPartReader) and part.name is not None:
                fields[part.name] = (part.filename, await part.read())
        if "model" not in fields or not fields["model"][1]:
            return self._reject(400, Invalid("you must provide a model parameter", "model"))
        if "file" not in fields or not fields["file"][0]:
            return self._reject(400, Invalid("Missing required parameter: 'file'.", "file"))
        filename, audio = fields["file"]
        extension = str(filename).rsplit(".", 1)[-1].lower()
        if extension not in AUDIO_FORMATS:
            return self._reject(
                400,
                Invalid(
                    f"Invalid file format. Supported formats: {list(AUDIO_FORMATS)}",
                    "file",
                    "invalid_value",
                ),
            )
        if not audio:
            return self._reject(400, Invalid("Audio file is empty.", "file", "invalid_value"))
        with self._lock:
            self.transcriptions.append({"model": fields["model"][1].decode(), "file": filename})
        return web.json_response({"text": self.transcriber(bytes(audio), str(filename))})
