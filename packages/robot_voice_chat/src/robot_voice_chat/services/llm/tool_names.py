"""Tool names on the wire (ARCHITECTURE §6a): ``server.tool`` inside the brain, ``server__tool``
for every LLM provider, which accept only ``^[a-zA-Z0-9_-]{1,64}$``.

One :class:`ToolNames` map is built per request from the tool list; it is a bijection (a
collision is a :class:`ToolNameError`), so a name that comes back from the model maps to
exactly one app name. A name the model made up maps to itself and reaches the tool backend,
which answers it with a clean "unknown tool" error the model can read.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Iterable

import structlog

logger = structlog.get_logger(__name__)

WIRE_PATTERN = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")
MAX_LEN = 64
SEP = "__"
_INVALID = re.compile(r"[^a-zA-Z0-9_-]")


class ToolNameError(ValueError):
    """Two tools would travel under the same wire name."""


def encode(name: str) -> str:
    """``navigation.navigate_to`` → ``navigation__navigate_to``; always matches the pattern.

    Characters the providers refuse become ``_``; names that had to be altered that way or
    are longer than 64 characters get a short hash suffix so distinct names stay distinct.
    """
    wire = name.replace(".", SEP)
    if WIRE_PATTERN.match(wire):
        return wire
    digest = hashlib.sha256(name.encode()).hexdigest()[:8]
    cleaned = _INVALID.sub("_", wire) or "tool"
    return f"{cleaned[: MAX_LEN - len(digest) - 1]}_{digest}"


class ToolNames:
    """The reversible app ↔ wire mapping for one request's tools."""

    def __init__(self, app_names: Iterable[str] = ()) -> None:
        self._to_wire: dict[str, str] = {}
        self._to_app: dict[str, str] = {}
        for name in app_names:
            self.add(name)

    def add(self, name: str) -> str:
        if name in self._to_wire:
            return self._to_wire[name]
        wire = encode(name)
        other = self._to_app.get(wire)
        if other is not None:
            raise ToolNameError(
                f"tools {other!r} and {name!r} would both be sent as {wire!r}; rename one"
            )
        self._to_wire[name] = wire
        self._to_app[wire] = name
        return wire

    def wire(self, name: str) -> str:
        """The wire name of an app name (names from the history not in the list: encoded)."""
        known = self._to_wire.get(name)
        if known is not None:
            return known
        return name if WIRE_PATTERN.match(name) else encode(name)

    def app(self, wire: str) -> str:
        """The app name of a wire name; an unknown name stays as the model sent it."""
        name = self._to_app.get(wire)
        if name is None:
            logger.warning("unknown_tool_name", name=wire[:100])
            return wire
        return name

    def knows(self, wire: str) -> bool:
        return wire in self._to_app
