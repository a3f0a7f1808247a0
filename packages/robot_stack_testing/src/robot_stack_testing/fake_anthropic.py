"""A local Anthropic Messages API that rejects what the real one rejects.

``POST /v1/messages`` validates every request before a scripted ``responder`` answers it:
``max_tokens`` and ``model`` present, no sampling parameters or ``budget_tokens`` with
adaptive thinking, tool names matching ``^[a-zA-Z0-9_-]{1,64}$`` and unique, the first
message from the user and roles alternating (our adapter merges runs; a run here is a bug),
no empty text blocks, every ``tool_use`` answered by a ``tool_result`` in the very next user
turn (results first), no ``tool_result`` without its ``tool_use``, and thinking blocks passed
back unchanged (signature) and first in the latest tool-use turn. A rejection is a 400 with
the API's error shape (``{"type": "error", "error": {"type": "invalid_request_error", ...}}``).

The responder gets the request body and returns content blocks (``text`` / ``tool_use``
without ids); the fake adds a signed thinking block, ids, ``stop_reason`` and a usage
estimate (4 characters per token, the tools + system prefix read from cache when unchanged).
``fail_status`` makes every call fail like an outage (401, 429, 500, 529); ``fail_next``
fails only the next calls (one status each, for retries); ``delay_s`` delays every answer.
"""

from __future__ import annotations

import asyncio
import hashlib
import hmac
import itertools
import json
import math
import re
import threading
from collections.abc import AsyncIterator, Callable
from typing import Any

from aiohttp import web

NAME = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")
Responder = Callable[[dict[str, Any]], list[dict[str, Any]]]
ERROR_TYPES = {
    400: "invalid_request_error",
    401: "authentication_error",
    429: "rate_limit_error",
    500: "api_error",
    529: "overloaded_error",
}
_SECRET = b"fake-anthropic-thinking"


def tokens(value: Any) -> int:
    return math.ceil(len(json.dumps(value, separators=(",", ":"))) / 4) if value else 0


def sign(thinking: str) -> str:
    return hmac.new(_SECRET, thinking.encode(), hashlib.sha256).hexdigest()


def _blocks(message: dict[str, Any]) -> list[dict[str, Any]]:
    content = message.get("content")
    if isinstance(content, str):
        return [{"type": "text", "text": content}]
    return [b for b in content if isinstance(b, dict)] if isinstance(content, list) else []


def _check_params(body: dict[str, Any]) -> str | None:
    if "max_tokens" not in body:
        return "max_tokens: Field required"
    if not isinstance(body["max_tokens"], int) or body["max_tokens"] < 1:
        return "max_tokens: Input should be a valid integer greater than or equal to 1"
    if not isinstance(body.get("model"), str) or not body["model"]:
        return "model: Field required"
    thinking = body.get("thinking")
    if isinstance(thinking, dict) and thinking.get("type") == "adaptive":
        if "budget_tokens" in thinking:
            return "thinking.adaptive.budget_tokens: Extra inputs are not permitted"
        for key in ("temperature", "top_p", "top_k"):
            if key in body:
                return f"`{key}` is not supported with adaptive thinking on this model"
    names: set[str] = set()
    for i, tool in enumerate(body.get("tools") or []):
        name = tool.get("name") if isinstance(tool, dict) else None
        if not isinstance(name, str) or not NAME.match(name):
            return f"tools.{i}.custom.name: String should match pattern '^[a-zA-Z0-9_-]{{1,64}}$'"
        if name in names:
            return "tools: Tool names must be unique."
        names.add(name)
        schema = tool.get("input_schema")
        if not isinstance(schema, dict):
            return f"tools.{i}.custom.input_schema: Field required"
        if schema.get("type") != "object":
            return f"tools.{i}.custom.input_schema.type: Input should be 'object'"
    return None


def _check_roles(messages: list[Any]) -> str | None:
    if not messages:
        return "messages: at least one message is required"
    for i, message in enumerate(messages):
        if not isinstance(message, dict) or message.get("role") not in ("user", "assistant"):
            return f"messages.{i}.role: Input should be 'user' or 'assistant'"
        if i and message["role"] == messages[i - 1]["role"]:
            return (
                'messages: roles must alternate between "user" and "assistant", but found '
                f'multiple "{message["role"]}" roles in a row'
            )
    if messages[0]["role"] != "user":
        return 'messages: first message must use the "user" role'
    return None


def _check_blocks(messages: list[dict[str, Any]]) -> str | None:
    last = len(messages) - 1
    for i, message in enumerate(messages):
        blocks = _blocks(message)
        if not blocks and not (i == last and message["role"] == "assistant"):
            return (
                f"messages.{i}: all messages must have non-empty content except for the "
                "optional final assistant message"
            )
        for j, block in enumerate(blocks):
            kind = block.get("type")
            if kind == "text" and not str(block.get("text", "")).strip():
                return f"messages.{i}.content.{j}.text: text content blocks must be non-empty"
            if kind == "tool_use" and not NAME.match(str(block.get("name", ""))):
                return (
                    f"messages.{i}.content.{j}.tool_use.name: String should match pattern "
                    "'^[a-zA-Z0-9_-]{1,64}$'"
                )
            if kind == "thinking" and block.get("signature") != sign(str(block.get("thinking"))):
                return f"messages.{i}.content.{j}: Invalid `signature` in `thinking` block"
    return None


def _check_tool_pairing(messages: list[dict[str, Any]]) -> str | None:
    for i, message in enumerate(messages):
        blocks = _blocks(message)
        if message["role"] == "assistant":
            used = [b.get("id") for b in blocks if b.get("type") == "tool_use"]
            if not used or i == len(messages) - 1:
                continue
            answered = {
                b.get("tool_use_id")
                for b in _blocks(messages[i + 1])
                if b.get("type") == "tool_result"
            }
            missing = [u for u in used if u not in answered]
            if missing:
                return (
                    f"messages.{i + 1}: `tool_use` ids were found without `tool_result` blocks "
                    f"immediately after: {', '.join(map(str, missing))}. Each `tool_use` block "
                    "must have a corresponding `tool_result` block in the next message."
                )
            continue
        previous = _blocks(messages[i - 1]) if i else []
        offered = {b.get("id") for b in previous if b.get("type") == "tool_use"}
        seen_other = False
        for j, block in enumerate(blocks):
            if block.get("type") != "tool_result":
                seen_other = True
                continue
            if seen_other:
                return (
                    f"messages.{i}.content.{j}: tool_result blocks must come first in the "
                    "user message, before any other content"
                )
            if block.get("tool_use_id") not in offered:
                return (
                    f"messages.{i}.content.{j}: unexpected `tool_use_id` found in "
                    f"`tool_result` blocks: {block.get('tool_use_id')}. Each `tool_result` "
                    "block must have a corresponding `tool_use` block in the previous message."
                )
    return None


def validate(body: dict[str, Any], thought: dict[str, str]) -> str | None:
    """The first rule ``body`` breaks, as the real API words it; ``None`` if it is valid.

    ``thought`` maps tool_use ids this fake issued to the signature of the thinking block
    that came with them (thinking must be passed back in the latest tool-use turn)."""
    messages = body.get("messages")
    if not isinstance(messages, list):
        return "messages: Field required"
    problem = (
        _check_params(body)
        or _check_roles(messages)
        or _check_blocks(messages)
        or _check_tool_pairing(messages)
    )
    if problem or not isinstance(body.get("thinking"), dict):
        return problem
    for i in range(len(messages) - 1, -1, -1):
        blocks = _blocks(messages[i])
        uses = [b.get("id") for b in blocks if b.get("type") == "tool_use"]
        if messages[i]["role"] != "assistant" or not uses:
            continue
        expected = next((thought[u] for u in uses if u in thought), None)
        first = blocks[0]
        if expected is not None and (
            first.get("type") != "thinking" or first.get("signature") != expected
        ):
            return (
                f"messages.{i}.content.0.type: Expected `thinking` or `redacted_thinking`, "
                f"but found `{first.get('type')}`. When `thinking` is enabled, a final "
                "`assistant` message must start with a thinking block."
            )
        break
    return None


def error_body(status: int, message: str) -> dict[str, Any]:
    return {
        "type": "error",
        "error": {"type": ERROR_TYPES.get(status, "api_error"), "message": message},
        "request_id": "req_fake",
    }


class FakeAnthropicApi:
    """The Messages API on loopback; ``app()`` for :func:`serve_in_thread`."""

    def __init__(self, responder: Responder, *, think: bool = True) -> None:
        self.responder = responder
        self.think = think
        self.requests: list[dict[str, Any]] = []
        self.rejections: list[str] = []
        self.fail_status: int | None = None
        self.fail_next: list[int] = []
        self.delay_s = 0.0
        self._thought: dict[str, str] = {}
        self._prefixes: set[str] = set()
        self._ids = itertools.count(1)
        self._lock = threading.Lock()

    def app(self) -> web.Application:
        app = web.Application()
        app.router.add_post("/v1/messages", self._messages)
        return app

    def _reject(self, status: int, message: str) -> web.Response:
        self.rejections.append(message)
        return web.json_response(error_body(status, message), status=status)

    async def _messages(self, request: web.Request) -> web.StreamResponse:
        bearer = request.headers.get("Authorization", "").removeprefix("Bearer ").strip()
        if not request.headers.get("x-api-key") and not bearer:
            return self._reject(401, "x-api-key header is required")
        if not request.headers.get("anthropic-version"):
            return self._reject(400, "anthropic-version: header is required")
        try:
            body = await request.json()
        except ValueError:
            return self._reject(400, "The request body is not valid JSON.")
        if self.delay_s:
            await asyncio.sleep(self.delay_s)
        status = self.fail_next.pop(0) if self.fail_next else self.fail_status
        if status is not None:
            return web.json_response(error_body(status, "fake outage"), status=status)
        with self._lock:
            problem = validate(body, self._thought)
            if problem is not None:
                return self._reject(400, problem)
            self.requests.append(body)
            message = self._answer(body)
        if body.get("stream"):
            return await _stream(request, message)
        return web.json_response(message)

    def _answer(self, body: dict[str, Any]) -> dict[str, Any]:
        n = next(self._ids)
        content: list[dict[str, Any]] = []
        if self.think and isinstance(body.get("thinking"), dict):
            text = f"Step {n}: deciding the next action."
            content.append({"type": "thinking", "thinking": text, "signature": sign(text)})
        for k, block in enumerate(self.responder(body)):
            if block.get("type") == "tool_use":
                block = {**block, "id": f"toolu_fake_{n}_{k}"}
                if content and content[0]["type"] == "thinking":
                    self._thought[block["id"]] = content[0]["signature"]
            content.append(block)
        prefix = json.dumps([body.get("tools"), body.get("system")], sort_keys=True)
        cached = prefix in self._prefixes
        self._prefixes.add(prefix)
        prefix_tokens = tokens([body.get("tools"), body.get("system")])
        return {
            "id": f"msg_fake_{n}",
            "type": "message",
            "role": "assistant",
            "model": body["model"],
            "content": content,
            "stop_reason": "tool_use"
            if any(b["type"] == "tool_use" for b in content)
            else "end_turn",
            "stop_sequence": None,
            "usage": {
                "input_tokens": tokens(body["messages"]),
                "output_tokens": tokens(content),
                "cache_read_input_tokens": prefix_tokens if cached else 0,
                "cache_creation_input_tokens": 0 if cached else prefix_tokens,
            },
        }


async def _stream(request: web.Request, message: dict[str, Any]) -> web.StreamResponse:
    response = web.StreamResponse(headers={"Content-Type": "text/event-stream"})
    await response.prepare(request)
    async for event in _events(message):
        data = f"event: {event['type']}\ndata: {json.dumps(event)}\n\n"
        await response.write(data.encode())
    await response.write_eof()
    return response


async def _events(message: dict[str, Any]) -> AsyncIterator[dict[str, Any]]:
    start = {**message, "content": [], "stop_reason": None}
    yield {"type": "message_start", "message": start}
    for index, block in enumerate(message["content"]):
        kind = block["type"]
        empty: dict[str, Any] = {"type": kind}
        if kind == "text":
            empty["text"] = ""
        elif kind == "thinking":
            empty.update(thinking="", signature="")
        else:
            empty.update(id=block["id"], name=block["name"], input={})
        yield {"type": "content_block_start", "index": index, "content_block": empty}
        if kind == "text":
            for word in re.findall(r"\S+\s*", block["text"]):
                delta = {"type": "text_delta", "text": word}
                yield {"type": "content_block_delta", "index": index, "delta": delta}
        elif kind == "thinking":
            for delta in (
                {"type": "thinking_delta", "thinking": block["thinking"]},
                {"type": "signature_delta", "signature": block["signature"]},
            ):
                yield {"type": "content_block_delta", "index": index, "delta": delta}
        else:
            delta = {"type": "input_json_delta", "partial_json": json.dumps(block["input"])}
            yield {"type": "content_block_delta", "index": index, "delta": delta}
        yield {"type": "content_block_stop", "index": index}
    end = {"stop_reason": message["stop_reason"], "stop_sequence": None}
    usage = {"output_tokens": message["usage"]["output_tokens"]}
    yield {"type": "message_delta", "delta": end, "usage": usage}
    yield {"type": "message_stop"}
