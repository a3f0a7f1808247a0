from pathlib import Path

import pytest

from robot_mcp_memory.config import ConfigError, MemoryConfig


def test_defaults_apply_when_nothing_is_set() -> None:
    config = MemoryConfig.from_env({})

    assert config.store == "sqlite"
    assert config.visibility == "robot"
    assert config.db_path.is_absolute()
    assert config.db_path.parent.name == "robot-mcp-memory"
    assert config.robot_id == "robot-1"
    assert config.reranker == "none"
    assert config.synonyms is True


def test_environment_variables_override_the_defaults() -> None:
    config = MemoryConfig.from_env(
        {
            "MEMORY_DB": "/data/m.sqlite3",
            "ROBOT_ID": " mailbot ",
            "MEMORY_OUTCOME_WEIGHT": "0.25",
            "MEMORY_CANDIDATES": "80",
            "MEMORY_SYNONYMS": "false",
            "MEMORY_CONCEPT_WEIGHT": "1.0",
            "MEMORY_RERANKER": "minilm",
            "MEMORY_RERANK_WEIGHT": "0.3",
            "MEMORY_TIMEOUT_S": "2.5",
            "UNRELATED": "x",
        }
    )

    assert config.db_path == Path("/data/m.sqlite3")
    assert config.robot_id == "mailbot"
    assert config.outcome_weight == 0.25
    assert config.candidate_pool == 80
    assert config.synonyms is False
    assert config.concept_weight == 1.0
    assert config.reranker == "minilm"
    assert config.rerank_weight == 0.3
    assert config.timeout_s == 2.5


def test_an_invalid_setting_names_its_environment_variable() -> None:
    with pytest.raises(ConfigError) as caught:
        MemoryConfig.from_env({"MEMORY_OUTCOME_WEIGHT": "3", "MEMORY_RERANKER": "bert"})

    message = str(caught.value)
    assert "MEMORY_OUTCOME_WEIGHT" in message
    assert "MEMORY_RERANKER" in message


def test_a_blank_robot_id_is_refused() -> None:
    with pytest.raises(ConfigError, match="ROBOT_ID"):
        MemoryConfig.from_env({"ROBOT_ID": "   "})


def test_the_default_database_lives_in_the_per_user_data_dir(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))

    config = MemoryConfig.from_env({})

    assert config.db_path == tmp_path / "data" / "robot-mcp-memory" / "memory.sqlite3"


def test_a_relative_database_path_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"MEMORY_DB: .*absolute path"):
        MemoryConfig.from_env({"MEMORY_DB": "var/memory.sqlite3"})


def test_postgres_needs_a_dsn_and_defaults_to_fleet_visibility() -> None:
    with pytest.raises(ConfigError, match="needs MEMORY_POSTGRES_DSN"):
        MemoryConfig.from_env({"MEMORY_STORE": "postgres"})

    config = MemoryConfig.from_env(
        {"MEMORY_STORE": "postgres", "MEMORY_POSTGRES_DSN": "postgresql://u:hunter2@db/memory"}
    )

    assert config.visibility == "fleet"
    assert "hunter2" not in repr(config)
    assert MemoryConfig.from_env({**{"MEMORY_VISIBILITY": "robot"}}).visibility == "robot"


def test_an_unknown_store_or_visibility_is_refused() -> None:
    with pytest.raises(ConfigError) as caught:
        MemoryConfig.from_env({"MEMORY_STORE": "mysql", "MEMORY_VISIBILITY": "world"})

    assert "MEMORY_STORE" in str(caught.value)
    assert "MEMORY_VISIBILITY" in str(caught.value)
