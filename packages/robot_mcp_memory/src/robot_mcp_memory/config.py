"""Settings of the memory server, read from the environment and validated at start-up.

- ``MEMORY_STORE`` (``sqlite``): ``sqlite`` (embedded, one file) or ``postgres`` (a fleet's
  shared database)
- ``MEMORY_DB`` (``<per-user data dir>/memory.sqlite3``, e.g.
  ``~/.local/share/robot-mcp-memory/memory.sqlite3``): SQLite file, an absolute path (directory
  created); never relative to the working directory
- ``MEMORY_POSTGRES_DSN`` (secret, required with ``postgres``): libpq URI or key=value string
- ``MEMORY_POSTGRES_POOL`` (``8``): connections per server; ``MEMORY_CONNECT_TIMEOUT_S`` (``5``)
- ``ROBOT_ID`` (``robot-1``): the robot this server speaks for (saves, outcomes, ranking)
- ``MEMORY_VISIBILITY`` (``robot`` with sqlite, ``fleet`` with postgres): ``robot`` = this
  robot's processes only, ``fleet`` = one set of processes shared by every robot
- ``MEMORY_ROBOT_OUTCOME_FACTOR`` (``3``): how much more this robot's outcomes count in the
  ranking than another robot's (:mod:`.ranking`)
- ``MEMORY_OUTCOME_WEIGHT`` (``0.5``): ``w`` of the outcome boost (:mod:`.ranking`)
- ``MEMORY_CANDIDATES`` (``100``): text-search candidates re-ranked by coverage / outcomes
- ``MEMORY_SYNONYMS`` (``true``): search the synonym concepts of the query's words too
- ``MEMORY_CONCEPT_WEIGHT`` (``1.0``): weight of concept matches against literal word matches
- ``MEMORY_COVERAGE_WEIGHT`` (``0.5``): ``γ``, share of query coverage in the relevance
  (:mod:`.coverage`)
- ``MEMORY_RERANKER`` (``none``): ``none`` or ``minilm`` (needs the ``[embeddings]`` extra)
- ``MEMORY_RERANK_WEIGHT`` (``0.5``): ``β``, share of embedding similarity in the relevance
- ``MEMORY_TIMEOUT_S`` (``10``): deadline of one store call
- ``MCP_TRANSPORT`` / ``MCP_HOST`` / ``MCP_PORT`` (``stdio`` / ``127.0.0.1`` / ``9103``): read
  by ``robot_mcp_kit.mcp_runtime.run_server``
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import platformdirs
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SecretStr,
    ValidationError,
    field_validator,
    model_validator,
)

from robot_mcp_memory.store.base import Visibility

DEFAULT_PORT = 9103
SERVER_NAME = "memory"

APP_NAME = "robot-mcp-memory"

_ENV_FIELDS = {
    "MEMORY_STORE": "store",
    "MEMORY_DB": "db_path",
    "MEMORY_POSTGRES_DSN": "postgres_dsn",
    "MEMORY_POSTGRES_POOL": "postgres_pool_size",
    "MEMORY_CONNECT_TIMEOUT_S": "connect_timeout_s",
    "MEMORY_VISIBILITY": "visibility_setting",
    "MEMORY_ROBOT_OUTCOME_FACTOR": "robot_factor",
    "ROBOT_ID": "robot_id",
    "MEMORY_OUTCOME_WEIGHT": "outcome_weight",
    "MEMORY_CANDIDATES": "candidate_pool",
    "MEMORY_SYNONYMS": "synonyms",
    "MEMORY_CONCEPT_WEIGHT": "concept_weight",
    "MEMORY_COVERAGE_WEIGHT": "coverage_weight",
    "MEMORY_RERANKER": "reranker",
    "MEMORY_RERANK_WEIGHT": "rerank_weight",
    "MEMORY_TIMEOUT_S": "timeout_s",
}


class ConfigError(ValueError):
    """The environment holds an invalid setting; the message names the variable."""


class MemoryConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    store: Literal["sqlite", "postgres"] = "sqlite"
    db_path: Path = Field(default_factory=lambda: default_db_path())
    postgres_dsn: SecretStr | None = None
    postgres_pool_size: int = Field(default=8, ge=1, le=100)
    connect_timeout_s: float = Field(default=5.0, gt=0.0, le=120.0)
    robot_id: str = Field(default="robot-1", min_length=1, max_length=128)
    visibility_setting: Visibility | None = None
    robot_factor: float = Field(default=3.0, ge=1.0, le=100.0)
    outcome_weight: float = Field(default=0.5, ge=0.0, le=1.0)
    candidate_pool: int = Field(default=100, ge=1, le=1000)
    synonyms: bool = True
    concept_weight: float = Field(default=1.0, ge=0.0, le=2.0)
    coverage_weight: float = Field(default=0.5, ge=0.0, le=1.0)
    reranker: Literal["none", "minilm"] = "none"
    rerank_weight: float = Field(default=0.5, ge=0.0, le=1.0)
    timeout_s: float = Field(default=10.0, gt=0.0, le=300.0)

    @field_validator("robot_id")
    @classmethod
    def _robot_id_is_printable(cls, value: str) -> str:
        value = value.strip()
        if not value or not value.isprintable():
            raise ValueError("must be a non-empty printable name")
        return value

    @field_validator("db_path")
    @classmethod
    def _db_path_is_absolute(cls, value: Path) -> Path:
        value = value.expanduser()
        if not value.is_absolute():
            raise ValueError(
                "must be an absolute path (state never depends on the working directory)"
            )
        return value

    @model_validator(mode="after")
    def _postgres_needs_a_dsn(self) -> MemoryConfig:
        if self.store == "postgres" and not (
            self.postgres_dsn and self.postgres_dsn.get_secret_value().strip()
        ):
            raise ValueError("MEMORY_STORE=postgres needs MEMORY_POSTGRES_DSN")
        return self

    @property
    def visibility(self) -> Visibility:
        """The configured visibility, else ``fleet`` for a shared PostgreSQL, ``robot`` for
        an embedded SQLite file."""
        if self.visibility_setting is not None:
            return self.visibility_setting
        return "fleet" if self.store == "postgres" else "robot"

    @classmethod
    def from_env(cls, env: Mapping[str, str]) -> MemoryConfig:
        """Settings from environment variables (unset or empty → default)."""
        values = {field: env[name] for name, field in _ENV_FIELDS.items() if env.get(name)}
        try:
            return cls.model_validate(values)
        except ValidationError as exc:
            by_field = {field: name for name, field in _ENV_FIELDS.items()}
            problems = [
                f"{by_field[str(error['loc'][0])]}: {error['msg']}"
                if error["loc"]
                else error["msg"].removeprefix("Value error, ")
                for error in exc.errors()
            ]
            raise ConfigError("invalid memory server settings: " + "; ".join(problems)) from exc


def default_db_path() -> Path:
    """``memory.sqlite3`` in the per-user data directory (``$XDG_DATA_HOME/robot-mcp-memory``)."""
    return platformdirs.user_data_path(APP_NAME) / "memory.sqlite3"
