"""Settings of the memory server, read from the environment and validated at start-up.

- ``MEMORY_DB`` (``var/memory.sqlite3``): SQLite file of the process store (directory created)
- ``ROBOT_ID`` (``robot-1``): robot whose processes this server stores and finds
- ``MEMORY_OUTCOME_WEIGHT`` (``0.5``): ``w`` of the outcome boost (:mod:`.ranking`)
- ``MEMORY_CANDIDATES`` (``50``): BM25 candidates re-ordered by outcomes / embeddings
- ``MEMORY_SYNONYMS`` (``true``): search the synonym concepts of the query's words too
- ``MEMORY_CONCEPT_WEIGHT`` (``0.5``): weight of concept matches against literal word matches
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

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

DEFAULT_PORT = 9103
SERVER_NAME = "memory"

_ENV_FIELDS = {
    "MEMORY_DB": "db_path",
    "ROBOT_ID": "robot_id",
    "MEMORY_OUTCOME_WEIGHT": "outcome_weight",
    "MEMORY_CANDIDATES": "candidate_pool",
    "MEMORY_SYNONYMS": "synonyms",
    "MEMORY_CONCEPT_WEIGHT": "concept_weight",
    "MEMORY_RERANKER": "reranker",
    "MEMORY_RERANK_WEIGHT": "rerank_weight",
    "MEMORY_TIMEOUT_S": "timeout_s",
}


class ConfigError(ValueError):
    """The environment holds an invalid setting; the message names the variable."""


class MemoryConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    db_path: Path = Path("var/memory.sqlite3")
    robot_id: str = Field(default="robot-1", min_length=1, max_length=128)
    outcome_weight: float = Field(default=0.5, ge=0.0, le=1.0)
    candidate_pool: int = Field(default=50, ge=1, le=1000)
    synonyms: bool = True
    concept_weight: float = Field(default=0.5, ge=0.0, le=2.0)
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

    @classmethod
    def from_env(cls, env: Mapping[str, str]) -> MemoryConfig:
        """Settings from environment variables (unset or empty → default)."""
        values = {field: env[name] for name, field in _ENV_FIELDS.items() if env.get(name)}
        try:
            return cls.model_validate(values)
        except ValidationError as exc:
            by_field = {field: name for name, field in _ENV_FIELDS.items()}
            problems = [
                f"{by_field.get(str(error['loc'][0]), error['loc'][0])}: {error['msg']}"
                for error in exc.errors()
            ]
            raise ConfigError("invalid memory server settings: " + "; ".join(problems)) from exc
