"""The MCP SDK's transport errors as the backend's own lines (issue 31).

When a server goes away the SDK logs each failing transport task with ``logger.exception``
("Error in sse_reader", "Error in post_writer", …): a chained traceback for every task of
every lost connection. The backend already says it once, structured (``mcp_server_disconnected``
with the reason). This filter on the SDK's client loggers takes those records over: it keeps
the reason for the server whose supervisor task the failing task was started from (a context
variable the child tasks inherit) and drops the record; a record it cannot place becomes one
warning line without the traceback.
"""

from __future__ import annotations

import logging
from contextvars import ContextVar

import structlog

logger = structlog.get_logger("robot_voice_chat.services.tools.mcp")
SDK_LOGGERS = ("mcp.client.sse", "mcp.client.streamable_http", "mcp.client.stdio")
# The server whose supervisor task (or a task it started) is running.
current_server: ContextVar[str | None] = ContextVar("mcp_current_server", default=None)


def describe(exc: BaseException) -> str:
    """``Type: message`` of the innermost first exception (groups unwrapped)."""
    if isinstance(exc, BaseExceptionGroup) and exc.exceptions:
        return describe(exc.exceptions[0])
    return f"{type(exc).__name__}: {exc}"


class TransportErrors(logging.Filter):
    """Reasons of the latest transport failure per server (read by the supervisor)."""

    def __init__(self) -> None:
        super().__init__()
        self.reasons: dict[str, str] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        if not record.exc_info or record.exc_info[1] is None:
            return True
        reason = describe(record.exc_info[1])
        server = current_server.get()
        if server is not None:
            self.reasons[server] = reason
        else:
            logger.warning("mcp_transport_error", where=record.getMessage(), error=reason)
        return False

    def take(self, server: str) -> str | None:
        return self.reasons.pop(server, None)


def install() -> TransportErrors:
    """One filter on the SDK's client loggers (idempotent: the installed one is returned)."""
    for name in SDK_LOGGERS:
        for existing in logging.getLogger(name).filters:
            if isinstance(existing, TransportErrors):
                return existing
    errors = TransportErrors()
    for name in SDK_LOGGERS:
        logging.getLogger(name).addFilter(errors)
    return errors
