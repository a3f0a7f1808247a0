"""What a server's setting must be, said once: pydantic field types for the values the motion
servers' environments share (ROS names, state paths, the brain's event URL, log levels), and
the environment reader that names every bad value in one error.

    class Settings(BaseModel):
        pick_action: RosName = Field(default="/manipulation/pick", alias="MANIP_PICK_ACTION")

    settings = settings_from_environ(Settings, os.environ, "manipulation", ConfigError)
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Literal, TypeVar

from pydantic import AfterValidator, BaseModel, BeforeValidator, ValidationError

ROS_NAME = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")
"""An absolute ROS topic or action name: ``/`` then tokens of letters, digits, underscores."""


def absolute_ros_name(value: str) -> str:
    if not ROS_NAME.match(value):
        raise ValueError(
            "must be an absolute ROS name such as /navigate_to_pose "
            "(letters, digits, underscores, separated by /)"
        )
    return value


def absolute_path(value: Path) -> Path:
    if not value.is_absolute():
        raise ValueError("must be an absolute path (the working directory is not state)")
    return value


def http_url(value: str) -> str:
    if not value.startswith(("http://", "https://")):
        raise ValueError("must be an http:// or https:// URL")
    return value


def empty_is_none(value: object) -> object:
    """An empty variable is an unset one (systemd env files write ``KEY=``)."""
    return None if value in ("", None) else value


def _upper(value: object) -> object:
    return value.strip().upper() if isinstance(value, str) else value


def lower_case(value: object) -> object:
    return value.strip().lower() if isinstance(value, str) else value


RosName = Annotated[str, AfterValidator(absolute_ros_name)]
StatePath = Annotated[Path, AfterValidator(absolute_path)]
EventsUrl = Annotated[str, AfterValidator(http_url)]
LogLevel = Annotated[Literal["DEBUG", "INFO", "WARNING", "ERROR"], BeforeValidator(_upper)]

SettingsT = TypeVar("SettingsT", bound=BaseModel)


def settings_from_environ(
    model: type[SettingsT],
    environ: Mapping[str, str],
    what: str,
    error: type[ValueError],
) -> SettingsT:
    """The model from the variables it names (its fields' aliases); every bad value is named
    in one ``error``: "invalid <what> settings: NAV_LOCK_HZ: …; MCP_PORT: …"."""
    aliases = {field.alias for field in model.model_fields.values() if field.alias is not None}
    values = {key: value for key, value in environ.items() if key in aliases}
    try:
        return model.model_validate(values)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in err['loc'])}: {err['msg']}" for err in exc.errors()
        )
        raise error(f"invalid {what} settings: {problems}") from exc
