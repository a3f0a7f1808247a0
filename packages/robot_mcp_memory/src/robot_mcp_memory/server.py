"""Entry point ``robot-mcp-memory``: settings from the environment, then serve MCP.

``MCP_TRANSPORT`` = stdio (default) | sse | streamable-http, ``MCP_HOST`` (127.0.0.1) and
``MCP_PORT`` (9103) are handled by ``robot_mcp_kit.mcp_runtime.run_server``; the memory settings
are listed in :mod:`robot_mcp_memory.config`. Logs are JSON on stderr (stdout carries stdio MCP).
"""

from __future__ import annotations

import os

import structlog

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import run_server
from robot_mcp_memory.composition import build_memory
from robot_mcp_memory.config import DEFAULT_PORT, SERVER_NAME, ConfigError, MemoryConfig
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.tools import build_server

log = structlog.get_logger("robot_mcp_memory")


def main() -> None:
    configure_logging(SERVER_NAME)
    try:
        config = MemoryConfig.from_env(os.environ)
    except ConfigError as exc:
        log.error("memory_server_config_invalid", error=str(exc))
        raise SystemExit(2) from exc
    try:
        memory = build_memory(config)
    except (StoreError, ImportError) as exc:
        log.error("memory_store_unavailable", store=config.store, error=str(exc))
        raise SystemExit(2) from exc
    log.info(
        "memory_server_starting",
        robot_id=config.robot_id,
        store=config.store,
        visibility=config.visibility,
        db_path=str(config.db_path) if config.store == "sqlite" else None,
        reranker=config.reranker,
        transport=os.environ.get("MCP_TRANSPORT", "stdio"),
    )
    try:
        run_server(build_server(memory), default_port=DEFAULT_PORT)
    except KeyboardInterrupt:
        pass
    finally:
        memory.store.close()
        log.info("memory_server_stopped")


if __name__ == "__main__":
    main()
