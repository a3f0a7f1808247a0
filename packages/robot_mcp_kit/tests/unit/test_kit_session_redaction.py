"""Session ids never reach a log line (issue 35 item 5): uvicorn's access lines keep their
argument shape, the SDK's warnings lose the id whether it is a string or a UUID."""

from __future__ import annotations

import logging
import uuid

from uvicorn.logging import AccessFormatter

from robot_mcp_kit.http_serving import (
    REDACTED_LOGGERS,
    RedactSessionIds,
    install_session_redaction,
    redact_session_ids,
)

SESSION = uuid.UUID("0123456789abcdef0123456789abcdef")


def record(msg: str, *args: object, name: str = "uvicorn.access") -> logging.LogRecord:
    return logging.LogRecord(name, logging.INFO, __file__, 1, msg, args, None)


def test_an_access_line_keeps_its_shape_without_the_session_id() -> None:
    access = record(
        '%s - "%s %s HTTP/%s" %d',
        "127.0.0.1:5000",
        "POST",
        f"/messages/?session_id={SESSION.hex}",
        "1.1",
        202,
    )
    assert RedactSessionIds().filter(access) is True
    line = AccessFormatter('%(client_addr)s - "%(request_line)s" %(status_code)s').format(access)
    assert SESSION.hex not in line
    assert "/messages/?session_id=<redacted>" in line
    assert line.endswith(" 202 Accepted")


def test_the_sdks_warnings_lose_the_id_in_any_form() -> None:
    for arg in (SESSION, SESSION.hex, str(SESSION)):
        warning = record("Rejecting message for session %s: no", arg, name="mcp.server.sse")
        RedactSessionIds().filter(warning)
        assert warning.getMessage() == "Rejecting message for session <session>: no"
    count = record("handled %d requests", 3)
    RedactSessionIds().filter(count)
    assert count.getMessage() == "handled 3 requests"


def test_the_filter_is_installed_once_on_each_logger() -> None:
    install_session_redaction()
    install_session_redaction()
    for name in REDACTED_LOGGERS:
        filters = logging.getLogger(name).filters
        assert sum(isinstance(f, RedactSessionIds) for f in filters) == 1
    assert redact_session_ids("GET /sse HTTP/1.1") == "GET /sse HTTP/1.1"
