from pathlib import Path

import platformdirs
import pytest

from robot_mcp_navigation.config import ConfigError, default_map_path, load_settings


def test_defaults_need_no_environment() -> None:
    settings = load_settings({})

    assert settings.map_path == default_map_path()
    assert settings.map_path.is_file()
    assert settings.time_scale == 1.0
    assert settings.port == 9101
    assert settings.host == "127.0.0.1"
    assert settings.transport == "stdio"
    assert settings.event_secret is None
    assert settings.events_url == "http://127.0.0.1:8000/api/agent/events"
    assert settings.outbox_path.is_absolute()
    assert settings.outbox_path.parent == platformdirs.user_data_path("robot-mcp-navigation")


def test_a_relative_outbox_path_is_refused_the_working_directory_is_not_state() -> None:
    with pytest.raises(ConfigError, match="NAV_OUTBOX"):
        load_settings({"NAV_OUTBOX": "var/outbox.sqlite3"})


def test_environment_values_are_parsed_and_the_secret_is_hidden() -> None:
    settings = load_settings(
        {
            "NAV_MAP": "/maps/x.yaml",
            "NAV_TIME_SCALE": "20",
            "NAV_FAILURES": "false",
            "RVC_EVENT_SECRET": "s3cret",
            "MCP_TRANSPORT": "sse",
            "MCP_PORT": "9999",
            "LOG_LEVEL": "debug",
            "UNRELATED": "ignored",
        }
    )

    assert settings.map_path == Path("/maps/x.yaml")
    assert settings.time_scale == 20.0
    assert settings.failures_enabled is False
    assert settings.event_secret is not None
    assert settings.event_secret.get_secret_value() == "s3cret"
    assert "s3cret" not in repr(settings)
    assert (settings.transport, settings.port, settings.log_level) == ("sse", 9999, "DEBUG")


def test_an_empty_secret_counts_as_no_secret() -> None:
    assert load_settings({"RVC_EVENT_SECRET": ""}).event_secret is None


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("NAV_TIME_SCALE", "0"),
        ("NAV_TIME_SCALE", "fast"),
        ("MCP_TRANSPORT", "carrier-pigeon"),
        ("MCP_PORT", "70000"),
        ("RVC_EVENTS_URL", "ftp://brain"),
    ],
)
def test_bad_values_are_refused_naming_the_variable(name: str, value: str) -> None:
    with pytest.raises(ConfigError, match=name):
        load_settings({name: value})
