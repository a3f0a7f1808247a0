"""Secrets never reach a log line: the values of secret environment variables are redacted
from structlog events and stdlib records alike."""

from __future__ import annotations

import json
import logging

import pytest
import structlog
import structlog.testing
from pydantic import BaseModel, SecretStr, ValidationError, field_validator

from robot_voice_chat.composition import validation_summary
from robot_voice_chat.logging import REDACTED, RedactSecrets, configure_logging, secret_values
from robot_voice_chat.services.tools import mcp_logs

SECRET = "s3cr3t-value-of-the-test"


def test_only_secret_looking_names_with_real_values_are_redacted() -> None:
    env = {
        "ADMIN_SECRET_KEY": SECRET,
        "GROQ_API_KEY": "gsk-123456",
        "ADMIN_PASSWORD_HASH": "$argon2id$v=19$abc",
        "NAV_EVENT_SECRET": "tiny",  # too short to redact safely
        "HOME": "/root/home-dir",
    }
    assert secret_values(env) == [SECRET, "$argon2id$v=19$abc", "gsk-123456"]


def test_secrets_are_replaced_in_nested_values() -> None:
    redact = RedactSecrets([SECRET])
    event = redact(None, "error", {"event": "x", "error": f"bad {SECRET}!", "n": [SECRET, 3]})
    assert event == {"event": "x", "error": f"bad {REDACTED}!", "n": [REDACTED, 3]}


def test_no_secret_reaches_stderr_from_structlog_or_stdlib(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    monkeypatch.setenv("ADMIN_SECRET_KEY", SECRET)
    handlers = logging.getLogger().handlers
    filters = [list(h.filters) for h in handlers]
    configure_logging("INFO", "json")
    try:
        structlog.get_logger("t").error("startup_refused", error=f"input_value='{SECRET}'")
        logging.getLogger("uvicorn.error").error("could not use %s", SECRET)
    finally:  # stderr is this test's capture: later tests must not log into it
        structlog.reset_defaults()
        for handler, kept in zip(handlers, filters, strict=True):
            handler.filters = kept
    err = capsys.readouterr().err
    assert SECRET not in err
    assert json.loads(err.splitlines()[0])["error"] == f"input_value='{REDACTED}'"
    assert f"could not use {REDACTED}" in caplog.text  # the root logger's handlers
    assert SECRET not in caplog.text


def test_validation_errors_name_the_field_but_never_the_value() -> None:
    class Settings(BaseModel):
        key: SecretStr

        @field_validator("key")
        @classmethod
        def _long(cls, value: SecretStr) -> SecretStr:
            raise ValueError("too short")

    with pytest.raises(ValidationError) as caught:
        Settings(key=SecretStr(SECRET))
    with pytest.raises(ValidationError) as raw:
        Settings.model_validate({"key": SECRET})
    assert SECRET in str(raw.value)  # what pydantic itself would print
    for exc in (caught.value, raw.value):
        assert validation_summary(exc) == "key: Value error, too short"


def test_an_mcp_transport_error_is_one_line_without_its_traceback() -> None:
    """Issue 31: the SDK logged "Error in sse_reader" with a chained traceback per task."""
    errors = mcp_logs.install()
    assert mcp_logs.install() is errors  # one filter, however many backends
    sdk = logging.getLogger("mcp.client.sse")
    handled: list[logging.LogRecord] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            handled.append(record)

    keep = Keep()
    sdk.addHandler(keep)
    try:
        with structlog.testing.capture_logs() as logs:
            try:
                raise ConnectionError("peer closed connection")
            except ConnectionError:
                sdk.exception("Error in sse_reader")  # no server in context: one line
            token = mcp_logs.current_server.set("memory")
            try:
                try:
                    raise ConnectionError("gone")
                except ConnectionError:
                    sdk.exception("Error in post_writer")  # kept for memory's own line
            finally:
                mcp_logs.current_server.reset(token)
    finally:
        sdk.removeHandler(keep)
    assert handled == []
    assert [(log["event"], log["error"]) for log in logs] == [
        ("mcp_transport_error", "ConnectionError: peer closed connection")
    ]
    assert errors.take("memory") == "ConnectionError: gone"
