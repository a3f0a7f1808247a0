"""structlog JSON logging (stderr) with request/turn/mission ids from contextvars."""

from __future__ import annotations

import logging
import os
import re
import sys
from collections.abc import Iterable, Mapping, MutableMapping
from typing import Any

import structlog

# Environment variables whose values never appear in a log line (redacted wherever they occur).
SECRET_NAME = re.compile(r"SECRET|PASSWORD|API_KEY|TOKEN|PRIVATE_KEY", re.IGNORECASE)
MIN_REDACTED_CHARS = 6  # shorter values would blank ordinary words
REDACTED = "[redacted]"
QUIET_LIBRARIES = ("httpx", "httpx2", "httpcore", "httpcore2")  # WARNING and up only


def secret_values(environ: Mapping[str, str] | None = None) -> list[str]:
    env = os.environ if environ is None else environ
    values = {v for k, v in env.items() if SECRET_NAME.search(k) and len(v) >= MIN_REDACTED_CHARS}
    return sorted(values, key=len, reverse=True)  # longest first: no partial leftovers


class RedactSecrets:
    """structlog processor: replaces the values of secret environment variables in every
    string of an event (messages, exception text, nested containers)."""

    def __init__(self, secrets: Iterable[str]) -> None:
        self._secrets = [s for s in secrets if s]

    def __call__(
        self, _: Any, __: str, event: MutableMapping[str, Any]
    ) -> MutableMapping[str, Any]:
        if self._secrets:
            for key, value in event.items():
                event[key] = self.clean(value)
        return event

    def clean(self, value: Any) -> Any:
        if isinstance(value, str):
            for secret in self._secrets:
                if secret in value:
                    value = value.replace(secret, REDACTED)
            return value
        if isinstance(value, dict):
            return {k: self.clean(v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            return type(value)(self.clean(v) for v in value)
        return value


def configure_logging(level: str = "INFO", fmt: str = "json") -> None:
    renderer: structlog.types.Processor = (
        structlog.dev.ConsoleRenderer() if fmt == "pretty" else structlog.processors.JSONRenderer()
    )
    redact = RedactSecrets(secret_values())
    structlog.configure(
        processors=[
            structlog.contextvars.merge_contextvars,
            structlog.processors.add_log_level,
            structlog.processors.TimeStamper(fmt="iso", utc=True),
            structlog.processors.StackInfoRenderer(),
            structlog.processors.format_exc_info,
            redact,
            renderer,
        ],
        wrapper_class=structlog.make_filtering_bound_logger(
            logging.getLevelNamesMapping().get(level.upper(), logging.INFO)
        ),
        logger_factory=structlog.PrintLoggerFactory(file=sys.stderr),
        cache_logger_on_first_use=False,
    )
    logging.basicConfig(level=level.upper(), stream=sys.stderr, format="%(name)s %(message)s")
    # one INFO line per HTTP request (every MCP health check, every event post) is noise
    for chatty in QUIET_LIBRARIES:
        logging.getLogger(chatty).setLevel(logging.WARNING)
    for handler in logging.getLogger().handlers:
        handler.addFilter(_RedactRecords(redact))


class _RedactRecords(logging.Filter):
    """The same redaction for stdlib loggers (uvicorn, httpx, libraries)."""

    def __init__(self, redact: RedactSecrets) -> None:
        super().__init__()
        self._redact = redact

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        cleaned = self._redact.clean(message)
        if cleaned != message:
            record.msg, record.args = cleaned, None
        return True
