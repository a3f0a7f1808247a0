"""Which browser origins may open a Socket.IO connection (ARCHITECTURE §6a).

python-socketio turns its origin check *off* for ``cors_allowed_origins=[]``, and a plain list
replaces its same-origin default, so the brain passes this callable instead: same origin (the
Origin's host equals the Host header — a page cannot forge Host) or an exact entry of
``api.cors_origins``. Requests without an Origin header (non-browser clients) are not checked
by python-socketio at all.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any
from urllib.parse import urlsplit

OriginCheck = Callable[[str | None, Mapping[str, Any]], bool]


def origin_policy(allowed: Iterable[str]) -> OriginCheck:
    explicit = frozenset(allowed)

    def is_allowed(origin: str | None, environ: Mapping[str, Any]) -> bool:
        if origin is None:
            return False
        if origin in explicit:
            return True
        host = environ.get("HTTP_HOST")
        return bool(host) and urlsplit(origin).netloc.lower() == str(host).lower()

    return is_allowed
