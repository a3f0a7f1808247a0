"""Start-up refusals: a server that cannot start says why on one line and exits with code 2
(never a traceback)."""

from __future__ import annotations

import sys
from typing import NoReturn

from pydantic import ValidationError

EXIT_CONFIG = 2


def describe(error: Exception) -> str:
    """One line: the first problem of a pydantic error (field and message), else ``str``."""
    if isinstance(error, ValidationError) and error.errors():
        first = error.errors()[0]
        where = ".".join(str(part) for part in first.get("loc", ())) or "config"
        more = len(error.errors()) - 1
        tail = f" (and {more} more)" if more else ""
        return f"{where}: {first.get('msg', 'invalid')}{tail}"
    return " ".join(str(error).split()) or type(error).__name__


def refuse_to_start(service: str, error: Exception) -> NoReturn:
    sys.stderr.write(f"{service}: cannot start: {describe(error)}\n")
    sys.stderr.flush()
    raise SystemExit(EXIT_CONFIG)
