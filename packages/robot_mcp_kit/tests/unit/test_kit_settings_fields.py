from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import pytest
from pydantic import BaseModel, BeforeValidator, Field, SecretStr

from robot_mcp_kit.settings_fields import (
    EventsUrl,
    LogLevel,
    RosName,
    StatePath,
    empty_is_none,
    lower_case,
    settings_from_environ,
)


class SettingsError(ValueError):
    pass


class Settings(BaseModel):
    action: RosName = Field(default="/arm/pick", alias="T_ACTION")
    outbox: StatePath = Field(default=Path("/var/lib/t/outbox.sqlite3"), alias="T_OUTBOX")
    events_url: EventsUrl = Field(default="http://127.0.0.1:8000/events", alias="T_EVENTS_URL")
    secret: Annotated[SecretStr | None, BeforeValidator(empty_is_none)] = Field(
        default=None, alias="T_SECRET"
    )
    mode: Annotated[Literal["required", "off"], BeforeValidator(lower_case)] = Field(
        default="required", alias="T_MODE"
    )
    log_level: LogLevel = Field(default="INFO", alias="LOG_LEVEL")
    port: int = Field(default=9000, ge=1, le=65535, alias="T_PORT")


def load(environ: dict[str, str]) -> Settings:
    return settings_from_environ(Settings, environ, "test", SettingsError)


def test_values_are_read_from_their_variables_and_others_are_ignored() -> None:
    settings = load(
        {
            "T_ACTION": "/robot/arm/pick_2",
            "T_OUTBOX": "/tmp/o.sqlite3",
            "T_EVENTS_URL": "https://brain.local/api/agent/events",
            "T_SECRET": "s3cret",
            "T_MODE": " OFF ",
            "LOG_LEVEL": "debug",
            "PATH": "/usr/bin",  # not a setting
        }
    )
    assert settings.action == "/robot/arm/pick_2"
    assert settings.outbox == Path("/tmp/o.sqlite3")
    assert settings.secret is not None
    assert settings.secret.get_secret_value() == "s3cret"
    assert (settings.mode, settings.log_level) == ("off", "DEBUG")


def test_an_empty_secret_is_an_unset_one() -> None:
    assert load({"T_SECRET": ""}).secret is None


@pytest.mark.parametrize(
    ("variable", "value", "rule"),
    [
        ("T_ACTION", "arm/pick", "absolute ROS name"),
        ("T_ACTION", "/arm pick", "absolute ROS name"),
        ("T_ACTION", "/arm//pick", "absolute ROS name"),
        ("T_ACTION", "/2arm", "absolute ROS name"),
        ("T_OUTBOX", "state/outbox.sqlite3", "absolute path"),
        ("T_EVENTS_URL", "127.0.0.1:8000/events", "http:// or https:// URL"),
        ("LOG_LEVEL", "chatty", "DEBUG"),
        ("T_MODE", "maybe", "required"),
    ],
)
def test_a_bad_value_is_named_with_its_rule(variable: str, value: str, rule: str) -> None:
    with pytest.raises(SettingsError, match=rf"^invalid test settings: {variable}: .*{rule}"):
        load({variable: value})


def test_every_bad_value_is_named_in_one_error() -> None:
    with pytest.raises(SettingsError) as raised:
        load({"T_ACTION": "pick", "T_PORT": "0", "T_OUTBOX": "relative"})
    message = str(raised.value)
    assert all(name in message for name in ("T_ACTION", "T_PORT", "T_OUTBOX")), message
