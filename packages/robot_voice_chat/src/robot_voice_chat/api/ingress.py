"""Event-ingress helpers (spec §3): bounded raw-body read, single-valued headers, dedupe LRU,
authentication that answers every failure alike, and the two rate limits."""

from __future__ import annotations

import secrets
from collections import OrderedDict

from fastapi import Request
from limits import RateLimitItem, parse
from limits.storage import MemoryStorage
from limits.strategies import MovingWindowRateLimiter

from robot_mcp_kit.signing import SignatureError, verify
from robot_voice_chat.settings import McpServerConfig

# Verified against when the server is unknown or has no secret, so every 401 costs the same.
_DUMMY_SECRET = secrets.token_hex(32)


class BodyTooLargeError(Exception):
    pass


async def read_limited(request: Request, limit: int) -> bytes:
    """The raw body (the signature covers raw bytes), refusing more than ``limit`` bytes."""
    declared = request.headers.getlist("content-length")
    if declared and declared[0].isdigit() and int(declared[0]) > limit:
        raise BodyTooLargeError
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise BodyTooLargeError
        chunks.append(chunk)
    return b"".join(chunks)


def json_depth(value: object) -> int:
    """How deeply containers nest in a parsed JSON value (a scalar is 0), without recursion."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, depth + 1)
            stack.extend(
                (child, depth + 1) for child in (item.values() if isinstance(item, dict) else item)
            )
    return deepest


def single_header(request: Request, name: str) -> str | None:
    """The header's value if it was sent exactly once, else None (missing or duplicated)."""
    values = request.headers.getlist(name)
    return values[0] if len(values) == 1 else None


class Unauthorized(Exception):
    """Any authentication failure; ``reason`` goes to the log, never to the client."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def authenticate(
    servers: dict[str, McpServerConfig],
    server: str | None,
    ts: str | None,
    signature: str | None,
    body: bytes,
    tolerance_s: float,
) -> McpServerConfig:
    """The verified server's config, or :class:`Unauthorized`. The signature is checked even
    for unknown names (against a throwaway secret) so timing does not tell names apart."""
    if server is None or ts is None or signature is None:
        raise Unauthorized("malformed_header")
    cfg = servers.get(server)
    secret = cfg.event_secret if cfg is not None and cfg.can_post_events else None
    try:
        verify(
            secret.get_secret_value() if secret is not None else _DUMMY_SECRET,
            ts,
            body,
            signature,
            tolerance_s=tolerance_s,
        )
    except SignatureError as exc:
        if secret is not None:
            raise Unauthorized(exc.reason) from exc
    if cfg is None:
        raise Unauthorized("unknown_server")
    if secret is None:
        raise Unauthorized("no_event_secret")
    return cfg


class RateLimit:
    """A moving-window limit per key (``"120/minute"``), in process memory."""

    def __init__(self, limit: str) -> None:
        self._item: RateLimitItem = parse(limit)
        self._limiter = MovingWindowRateLimiter(MemoryStorage())

    def hit(self, key: str) -> bool:
        """Count one request for ``key``; False once the key is over its limit."""
        return bool(self._limiter.hit(self._item, key))


class DedupeLRU:
    """Event ids seen or in flight. ``reserve`` before handling, ``release`` if handling
    failed (the poster retries), so two concurrent copies of one event run once."""

    def __init__(self, size: int) -> None:
        self._size = size
        self._seen: OrderedDict[str, None] = OrderedDict()

    def __contains__(self, key: str) -> bool:
        if key in self._seen:
            self._seen.move_to_end(key)
            return True
        return False

    def reserve(self, key: str) -> bool:
        """Claim ``key``; False if it was already seen or is being handled."""
        if key in self:
            return False
        self.add(key)
        return True

    def release(self, key: str) -> None:
        self._seen.pop(key, None)

    def add(self, key: str) -> None:
        self._seen[key] = None
        self._seen.move_to_end(key)
        while len(self._seen) > self._size:
            self._seen.popitem(last=False)

    def __len__(self) -> int:
        return len(self._seen)
