from pathlib import Path

import pytest

from robot_mcp_memory.config import ConfigError, MemoryConfig


def test_defaults_apply_when_nothing_is_set() -> None:
    config = MemoryConfig.from_env({})

    assert config.db_path == Path("var/memory.sqlite3")
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
