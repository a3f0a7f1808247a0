"""structlog set-up shared by every server process: JSON lines on stderr.

stdio MCP servers use stdout for the protocol, so nothing here ever writes to stdout. Standard
library loggers (the MCP SDK, uvicorn, httpx) are routed through the same renderer.
"""

from __future__ import annotations

import logging
import os
import sys
from typing import Any

import structlog
from structlog.typing import EventDict, Processor, WrappedLogger

_HANDLER_NAME = "robot_mcp_kit"
_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


def _service_adder(service: str) -> Processor:
    def add_service(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
        event_dict.setdefault("service", service)
        return event_dict

    return add_service


def configure_logging(service: str, *, level: str = "INFO", json: bool = True) -> None:
    """Configure structlog + stdlib logging for ``service``.

    Environment overrides: ``LOG_LEVEL`` (DEBUG, INFO, ...) and ``LOG_FORMAT`` (``pretty`` for
    human-readable console output, ``json`` for JSON). Safe to call more than once.
    """
    level_name = os.environ.get("LOG_LEVEL", level).strip().upper()
    if level_name not in _LEVELS:
        raise ValueError(f"unknown log level {level_name!r}; use one of {', '.join(_LEVELS)}")
    log_format = os.environ.get("LOG_FORMAT", "").strip().lower()
    if log_format not in ("", "json", "pretty"):
        raise ValueError(f"unknown LOG_FORMAT {log_format!r}; use json or pretty")
    as_json = json if not log_format else log_format == "json"

    shared: list[Processor] = [
        structlog.contextvars.merge_contextvars,
        structlog.stdlib.add_log_level,
        structlog.stdlib.add_logger_name,
        structlog.processors.TimeStamper(fmt="iso", utc=True),
        _service_adder(service),
    ]
    renderer: Processor
    if as_json:
        renderer = structlog.processors.JSONRenderer()
        shared.append(structlog.processors.format_exc_info)
    else:
        renderer = structlog.dev.ConsoleRenderer(colors=False)

    structlog.configure(
        processors=[
            structlog.stdlib.filter_by_level,
            *shared,
            structlog.stdlib.PositionalArgumentsFormatter(),
            structlog.processors.StackInfoRenderer(),
            structlog.stdlib.ProcessorFormatter.wrap_for_formatter,
        ],
        logger_factory=structlog.stdlib.LoggerFactory(),
        wrapper_class=structlog.stdlib.BoundLogger,
        cache_logger_on_first_use=False,
    )
    formatter = structlog.stdlib.ProcessorFormatter(
        foreign_pre_chain=shared,
        processors=[structlog.stdlib.ProcessorFormatter.remove_processors_meta, renderer],
    )
    handler = logging.StreamHandler(sys.stderr)
    handler.set_name(_HANDLER_NAME)
    handler.setFormatter(formatter)
    root = logging.getLogger()
    for old in list(root.handlers):
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(level_name)


def get_logger(name: str | None = None, **initial: Any) -> Any:
    """A structlog logger (thin alias so servers need not import structlog themselves)."""
    return structlog.get_logger(name, **initial)
