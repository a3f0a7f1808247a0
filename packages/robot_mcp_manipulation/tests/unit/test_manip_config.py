"""Settings from the environment: defaults need nothing, bad values stop start-up with exit 2
and one line naming the variable."""

from __future__ import annotations

from pathlib import Path

import platformdirs
import pytest

from robot_mcp_manipulation.config import ConfigError, load_settings
from robot_stack_testing import start_refusal


def test_defaults_need_no_environment() -> None:
    settings = load_settings({})
    assert (settings.pick_action, settings.place_action) == (
        "/manipulation/pick",
        "/manipulation/place",
    )
    assert settings.held_topic == "/manipulation/held"
    assert (settings.host, settings.port, settings.transport) == ("127.0.0.1", 9102, "stdio")
    assert settings.event_secret is None
    assert settings.outbox_path.parent == platformdirs.user_data_path("robot-mcp-manipulation")


def test_values_are_parsed_and_the_secret_is_hidden() -> None:
    settings = load_settings(
        {"RVC_EVENT_SECRET": "s3cret", "MCP_TRANSPORT": "sse", "LOG_LEVEL": "debug", "X": "1"}
    )
    assert settings.event_secret is not None
    assert "s3cret" not in repr(settings)
    assert settings.log_level == "DEBUG"
    assert load_settings({"RVC_EVENT_SECRET": ""}).event_secret is None


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("MANIP_PICK_ACTION", "pick"),
        ("MANIP_OUTBOX", "var/outbox.sqlite3"),
        ("RVC_EVENTS_URL", "ftp://brain"),
        ("MCP_PORT", "0"),
    ],
)
def test_a_bad_value_is_refused_naming_it(name: str, value: str) -> None:
    with pytest.raises(ConfigError, match=name):
        load_settings({name: value})


def test_the_process_refuses_a_bad_setting_with_exit_2_and_one_line(tmp_path: Path) -> None:
    line = start_refusal("robot_mcp_manipulation", tmp_path, {"MCP_TRANSPORT": "carrier-pigeon"})
    assert "startup_failed" in line
    assert "MCP_TRANSPORT" in line


def test_the_readme_error_table_is_the_code_table() -> None:
    from robot_mcp_manipulation.arm.error_codes import CODES, FAILURES

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    for code, failure in FAILURES.items():
        numbers = ", ".join(f"{a} {n}" for (a, n), c in CODES.items() if c == code)
        row = (
            f"| `{code}` | {numbers} | {'yes' if failure.recoverable else 'no'} | "
            f"{failure.what} | {'; '.join(failure.suggestions)} |"
        )
        assert row in readme, row


def test_over_http_the_server_refuses_to_run_open(tmp_path: Path) -> None:
    line = start_refusal("robot_mcp_manipulation", tmp_path, {"MCP_TRANSPORT": "sse"})
    assert "MCP_AUTH_TOKEN" in line
