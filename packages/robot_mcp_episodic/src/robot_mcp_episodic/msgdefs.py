"""ROS 2 message definitions as rosbag2 stores them in an MCAP schema (``ros2msg``): the type's
own ``.msg`` text, then every type it uses, each after a ``====`` line and ``MSG: pkg/msg/T``.
Read from ``<prefix>/share/<pkg>/msg/*.msg`` for each prefix of ``AMENT_PREFIX_PATH`` and the
running interpreter's prefix (where the PyPI ROS wheels install them)."""

from __future__ import annotations

import os
import re
import sys
from functools import cache
from pathlib import Path

SEPARATOR = "=" * 80
_PRIMITIVES_TEXT = """
bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64
string wstring
"""
PRIMITIVES = frozenset(_PRIMITIVES_TEXT.split())
_BOUNDS = re.compile(r"(<=\d+)?(\[[^\]]*\])?$")


class MessageDefinitionError(LookupError):
    """The ``.msg`` file of a type is not installed."""


def _msg_path(type_name: str) -> Path:
    package, _, name = _full(type_name, "").partition("/msg/")
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, sys.prefix]:
        path = Path(prefix) / "share" / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path
    raise MessageDefinitionError(f"the message definition of {type_name} is not installed")


def _full(type_name: str, package: str) -> str:
    """``pkg/msg/T`` for ``pkg/msg/T``, ``pkg/T`` or (inside ``package``) ``T``."""
    parts = type_name.split("/")
    if len(parts) == 3:
        return type_name
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return f"{package}/msg/{type_name}"


def _dependencies(text: str, package: str) -> list[str]:
    found: list[str] = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        field_type = _BOUNDS.sub("", line.split()[0])
        if field_type in PRIMITIVES or "=" in line.split()[0]:
            continue
        full = _full(field_type, package)
        if full not in found:
            found.append(full)
    return found


@cache
def message_definition(type_name: str) -> str:
    """The rosbag2 ``ros2msg`` schema text of ``type_name`` (``pkg/msg/T``)."""
    root = _full(type_name, "")
    order: list[str] = []
    texts: dict[str, str] = {}
    pending = [root]
    while pending:
        current = pending.pop(0)
        if current in texts:
            continue
        texts[current] = _msg_path(current).read_text(encoding="utf-8")
        order.append(current)
        pending.extend(_dependencies(texts[current], current.split("/")[0]))
    parts = [texts[root].rstrip("\n")]
    for dependency in order[1:]:
        parts.append(f"{SEPARATOR}\nMSG: {dependency}\n{texts[dependency].rstrip(chr(10))}")
    return "\n".join(parts) + "\n"
