"""Event-ingress helpers (spec §3): bounded raw-body read, single-valued headers, dedupe LRU."""

from __future__ import annotations

from collections import OrderedDict

from fastapi import Request


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


def single_header(request: Request, name: str) -> str | None:
    """The header's value if it was sent exactly once, else None (missing or duplicated)."""
    values = request.headers.getlist(name)
    return values[0] if len(values) == 1 else None


class DedupeLRU:
    def __init__(self, size: int) -> None:
        self._size = size
        self._seen: OrderedDict[str, None] = OrderedDict()

    def __contains__(self, key: str) -> bool:
        if key in self._seen:
            self._seen.move_to_end(key)
            return True
        return False

    def add(self, key: str) -> None:
        self._seen[key] = None
        self._seen.move_to_end(key)
        while len(self._seen) > self._size:
            self._seen.popitem(last=False)

    def __len__(self) -> int:
        return len(self._seen)
