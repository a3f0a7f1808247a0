"""Settings of the episodic server, read from the environment and validated before anything
starts (a bad value exits 2 with one line naming the variable).

- ``EPISODIC_STORE`` (``sqlite``) | ``postgres``; ``EPISODIC_POSTGRES_DSN`` (secret, needed
  with ``postgres``)
- ``EPISODIC_DIR`` (per-user data dir, e.g. ``~/.local/share/robot-mcp-episodic``): the SQLite
  index ``episodic.sqlite3`` and the MCAP bags ``bags/``; an absolute path
- ``EPISODIC_POSE_TOPIC`` (``/amcl_pose``, geometry_msgs/PoseWithCovarianceStamped)
- ``EPISODIC_MAP_FILE`` (the navigation server's ``office.yaml``): the named places
- ``EPISODIC_PLACE_RADIUS_M`` (``2.5``): a pose is "at" the nearest named place within this
- ``EPISODIC_FLUSH_S`` (``1``): index rows and MCAP chunks are written this often; a crash
  loses at most this much
- ``EPISODIC_ROTATE_S`` (``3600``): one bag per hour
- ``EPISODIC_RETAIN_BAGS_H`` (``72``), ``EPISODIC_RETAIN_INDEX_D`` (``90``): retention per kind
- ``EPISODIC_MAX_MB`` (``2048``): size cap of bags + index, oldest bags go first
- ``EPISODIC_JANITOR_S`` (``60``): how often retention and the size cap run
- ``EPISODIC_GAP_S`` (``10``): a re-sighting after this gap starts a new interval
- ``EPISODIC_INDEX_HZ`` (``2``) / ``EPISODIC_POSE_HZ`` (``5``): frames per skill topic and
  poses per second decoded for the index (every message goes to the MCAP)
- ``EPISODIC_RECORD_RAW`` (``true``): write MCAP bags
- ``EPISODIC_TIMEZONE`` (the machine's local zone, else UTC): an IANA name
  (``Europe/Berlin``); clock times such as "3 pm" are read in it and answers give its wall
  clock beside the ISO UTC times
- ``ROBOT_ID`` (``robot-1``); ``MCP_TRANSPORT`` / ``MCP_HOST`` / ``MCP_PORT`` (stdio /
  127.0.0.1 / 9203)
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Literal
from zoneinfo import ZoneInfo

import platformdirs
import tzlocal
from pydantic import BaseModel, ConfigDict, Field, SecretStr, field_validator, model_validator

from robot_mcp_episodic.timeparse import site_zone

DEFAULT_PORT = 9203
SERVER_NAME = "episodic"
APP_NAME = "robot-mcp-episodic"

_ENV = {
    "store": "EPISODIC_STORE",
    "postgres_dsn": "EPISODIC_POSTGRES_DSN",
    "data_dir": "EPISODIC_DIR",
    "pose_topic": "EPISODIC_POSE_TOPIC",
    "map_file": "EPISODIC_MAP_FILE",
    "place_radius_m": "EPISODIC_PLACE_RADIUS_M",
    "flush_s": "EPISODIC_FLUSH_S",
    "rotate_s": "EPISODIC_ROTATE_S",
    "retain_bags_h": "EPISODIC_RETAIN_BAGS_H",
    "retain_index_d": "EPISODIC_RETAIN_INDEX_D",
    "max_mb": "EPISODIC_MAX_MB",
    "janitor_s": "EPISODIC_JANITOR_S",
    "gap_s": "EPISODIC_GAP_S",
    "index_hz": "EPISODIC_INDEX_HZ",
    "pose_hz": "EPISODIC_POSE_HZ",
    "record_raw": "EPISODIC_RECORD_RAW",
    "timezone": "EPISODIC_TIMEZONE",
    "robot_id": "ROBOT_ID",
    "log_level": "LOG_LEVEL",
}


def default_map_file() -> Path:
    """The office map shipped with the navigation server (the same named places)."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        candidate = parent / "robot_mcp_navigation" / "config" / "maps" / "office.yaml"
        if candidate.is_file():
            return candidate
    return here.parent / "office.yaml"


def local_zone_name() -> str:
    """The machine's IANA zone (``TZ``, ``/etc/timezone``, the ``/etc/localtime`` link), else
    UTC."""
    try:
        name = tzlocal.get_localzone_name()
    except (LookupError, OSError, ValueError):  # tzlocal's "cannot tell" errors
        return "UTC"
    return name or "UTC"


class EpisodicConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    store: Literal["sqlite", "postgres"] = "sqlite"
    postgres_dsn: SecretStr | None = None
    data_dir: Path = Field(default_factory=lambda: platformdirs.user_data_path(APP_NAME))
    pose_topic: str = Field(default="/amcl_pose", pattern=r"^/[A-Za-z0-9_/]+$")
    map_file: Path = Field(default_factory=default_map_file)
    place_radius_m: float = Field(default=2.5, gt=0, le=100)
    flush_s: float = Field(default=1.0, gt=0, le=60)
    rotate_s: float = Field(default=3600.0, ge=10, le=86400)
    retain_bags_h: float = Field(default=72.0, gt=0)
    retain_index_d: float = Field(default=90.0, gt=0)
    max_mb: float = Field(default=2048.0, gt=0)
    janitor_s: float = Field(default=60.0, gt=0, le=3600)
    gap_s: float = Field(default=10.0, gt=0, le=3600)
    index_hz: float = Field(default=2.0, gt=0, le=100)
    pose_hz: float = Field(default=5.0, gt=0, le=100)
    record_raw: bool = True
    timezone: str = Field(default_factory=local_zone_name)
    graph_poll_s: float = Field(default=0.25, gt=0, le=30)
    robot_id: str = Field(default="robot-1", min_length=1, max_length=128)
    ros_node_name: str = "robot_mcp_episodic"
    log_level: str = "INFO"

    @field_validator("data_dir")
    @classmethod
    def _absolute(cls, value: Path) -> Path:
        value = value.expanduser()
        if not value.is_absolute():
            raise ValueError("must be an absolute path (never relative to the working directory)")
        return value

    @field_validator("timezone")
    @classmethod
    def _known_zone(cls, value: str) -> str:
        try:
            site_zone(value.strip())
        except ValueError as exc:  # the default too: a machine zone zoneinfo cannot read
            raise ValueError(f"{exc} (set EPISODIC_TIMEZONE)") from None
        return value.strip()

    @field_validator("map_file")
    @classmethod
    def _map_exists(cls, value: Path) -> Path:
        if not value.is_file():
            raise ValueError(f"no map file at {value}")
        return value

    @model_validator(mode="after")
    def _postgres_needs_a_dsn(self) -> EpisodicConfig:
        if self.store == "postgres" and not (
            self.postgres_dsn and self.postgres_dsn.get_secret_value().strip()
        ):
            raise ValueError("EPISODIC_STORE=postgres needs EPISODIC_POSTGRES_DSN")
        return self

    @property
    def zone(self) -> ZoneInfo:
        return site_zone(self.timezone)

    @property
    def db_path(self) -> Path:
        return self.data_dir / "episodic.sqlite3"

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> EpisodicConfig:
        env = os.environ if env is None else env
        return cls.model_validate({key: env[var] for key, var in _ENV.items() if env.get(var)})
