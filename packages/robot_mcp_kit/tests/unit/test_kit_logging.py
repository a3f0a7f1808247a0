from __future__ import annotations

import json
import logging
from collections.abc import Iterator

import pytest
import structlog

from robot_mcp_kit.logging import configure_logging, get_logger


@pytest.fixture(autouse=True)
def restore_logging() -> Iterator[None]:
    root = logging.getLogger()
    handlers, level = list(root.handlers), root.level
    yield
    for handler in list(root.handlers):
        root.removeHandler(handler)
    for handler in handlers:
        root.addHandler(handler)
    root.setLevel(level)
    structlog.reset_defaults()


def test_structlog_and_stdlib_records_are_json_lines_on_stderr(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("LOG_LEVEL", raising=False)
    monkeypatch.delenv("LOG_FORMAT", raising=False)
    configure_logging("navigation")
    get_logger("kit.test").info("event_delivered", task_id="t1", duration_ms=1.5)
    logging.getLogger("mcp.server").warning("sdk says %s", "hello")
    get_logger("kit.test").debug("too_detailed")

    out, err = capsys.readouterr()
    assert out == ""
    records = [json.loads(line) for line in err.splitlines()]
    assert [r["event"] for r in records] == ["event_delivered", "sdk says hello"]
    assert all(r["service"] == "navigation" for r in records)
    assert records[0]["task_id"] == "t1"
    assert records[0]["level"] == "info"
    assert records[1]["logger"] == "mcp.server"


def test_environment_overrides_level_and_format(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("LOG_LEVEL", "debug")
    monkeypatch.setenv("LOG_FORMAT", "pretty")
    configure_logging("memory")
    get_logger("kit.test").debug("detail_visible", n=1)
    out, err = capsys.readouterr()
    assert out == ""
    assert "detail_visible" in err
    assert "n=1" in err
    assert not err.lstrip().startswith("{")


def test_configuring_twice_keeps_a_single_handler(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("LOG_LEVEL", raising=False)
    monkeypatch.delenv("LOG_FORMAT", raising=False)
    configure_logging("a")
    configure_logging("b", level="WARNING")
    assert len(logging.getLogger().handlers) == 1
    assert logging.getLogger().level == logging.WARNING


@pytest.mark.parametrize(("name", "value"), [("LOG_LEVEL", "loud"), ("LOG_FORMAT", "xml")])
def test_bad_overrides_are_refused(monkeypatch: pytest.MonkeyPatch, name: str, value: str) -> None:
    monkeypatch.setenv(name, value)
    with pytest.raises(ValueError, match=f"(?i){value}"):
        configure_logging("x")
