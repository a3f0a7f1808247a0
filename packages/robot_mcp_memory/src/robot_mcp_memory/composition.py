"""Composition root of the memory server: the only place adapters are built."""

from __future__ import annotations

from collections.abc import Callable

from robot_mcp_memory.config import MemoryConfig
from robot_mcp_memory.coverage import CoverageReranker
from robot_mcp_memory.embeddings import Embedder, EmbeddingReranker, MiniLMEmbedder
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.base import ProcessStore
from robot_mcp_memory.store.sqlite_fts import SqliteFtsProcessStore

# Embedders by MEMORY_RERANKER name ("none" builds no re-ranker).
EMBEDDERS: dict[str, Callable[[], Embedder]] = {"minilm": MiniLMEmbedder}


def build_store(config: MemoryConfig) -> ProcessStore:
    """The configured store adapter; raises StoreError when it cannot be opened."""
    if config.store == "postgres" and config.postgres_dsn is not None:
        from robot_mcp_memory.store.postgres import PostgresProcessStore

        return PostgresProcessStore(
            config.postgres_dsn.get_secret_value(),
            config.robot_id,
            visibility=config.visibility,
            pool_size=config.postgres_pool_size,
            connect_timeout_s=config.connect_timeout_s,
        )
    return SqliteFtsProcessStore(config.db_path, config.robot_id, visibility=config.visibility)


def build_reranker(config: MemoryConfig) -> EmbeddingReranker | None:
    factory = EMBEDDERS.get(config.reranker)
    if factory is None:
        return None
    return EmbeddingReranker(factory(), weight=config.rerank_weight)


def build_memory(config: MemoryConfig, store: ProcessStore | None = None) -> ProcessMemory:
    """The process memory for ``config``; ``store`` replaces the configured adapter."""
    return ProcessMemory(
        store if store is not None else build_store(config),
        reranker=build_reranker(config),
        outcome_weight=config.outcome_weight,
        robot_factor=config.robot_factor,
        candidate_pool=config.candidate_pool,
        synonyms=config.synonyms,
        concept_weight=config.concept_weight,
        coverage=CoverageReranker(config.coverage_weight),
        timeout_s=config.timeout_s,
    )
