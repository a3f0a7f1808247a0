"""The composition root of ``robot-mcp-episodic``: the only place adapters are built.

ROS callbacks write to memory; the background :class:`~.worker.Worker` writes to disk every
``EPISODIC_FLUSH_S`` (default 1 s: what a crash loses), polls the graph for new skill topics
and enforces retention every ``EPISODIC_JANITOR_S``.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import structlog
from mcp.server.mcpserver import MCPServer

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.config import DEFAULT_PORT, EpisodicConfig
from robot_mcp_episodic.ingest import Indexer, IndexRules
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.retention import Janitor
from robot_mcp_episodic.ros_side import RosRecorder
from robot_mcp_episodic.server import build_server
from robot_mcp_episodic.service import Episodic, Retention
from robot_mcp_episodic.store.base import EpisodicStore, StoreError
from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore
from robot_mcp_episodic.worker import Job, Worker
from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import reserve_stdout, run_server, transport_settings
from robot_mcp_kit.startup import refuse_to_start
from robot_ros_bridge import RosBridge

SERVICE = "robot-mcp-episodic"
logger = structlog.get_logger(__name__)


def build_store(config: EpisodicConfig) -> EpisodicStore:
    """The configured store adapter; raises StoreError when it cannot be opened."""
    if config.store == "postgres" and config.postgres_dsn is not None:
        from robot_mcp_episodic.store.postgres import PostgresEpisodicStore

        return PostgresEpisodicStore(config.postgres_dsn.get_secret_value(), config.robot_id)
    return SqliteEpisodicStore(config.db_path, config.robot_id)


@dataclass
class EpisodicApp:
    config: EpisodicConfig
    memory: Episodic
    server: MCPServer
    worker: Worker
    recorder: RosRecorder | None = None
    bridge: RosBridge | None = None
    _closed: bool = field(default=False, repr=False)

    def close(self) -> None:
        """Stop recording, write what is pending, finish the open bag, close the store."""
        if self._closed:
            return
        self._closed = True
        self.worker.stop()
        if self.recorder is not None:
            self.recorder.close()
        try:
            self.memory.indexer.flush()
        finally:
            if self.memory.bags is not None:
                self.memory.bags.close()
            self.memory.store.close()
            if self.bridge is not None:
                self.bridge.close()


def build_app(
    config: EpisodicConfig,
    *,
    store: EpisodicStore | None = None,
    bridge: RosBridge | None = None,
    record_ros: bool = True,
    clock: Callable[[], float] = time.time,
) -> EpisodicApp:
    """Wire store, indexer, bags, ROS recorder, worker and the MCP server.

    ``record_ros=False`` builds no ROS node (tools-only tests); ``store`` replaces the
    configured adapter."""
    store = store if store is not None else build_store(config)
    places = Places.from_yaml(config.map_file, config.place_radius_m)
    indexer = Indexer(store, places, IndexRules(gap_s=config.gap_s), clock=clock)
    bags = BagRecorder(config.data_dir, config.rotate_s) if config.record_raw else None
    retention = Retention(
        config.retain_bags_h, config.retain_index_d, config.max_mb, config.flush_s
    )
    memory = Episodic(store, indexer, places, retention, bags, clock=clock, zone=config.zone)
    janitor = Janitor(
        store, bags, bags_h=config.retain_bags_h, index_d=config.retain_index_d,
        max_mb=config.max_mb, clock=clock,
    )  # fmt: skip
    recorder: RosRecorder | None = None
    if record_ros:
        # Single-threaded: the callbacks are short and never wait on each other, and the
        # multi-threaded executor costs ~5x the CPU per message (benchmarks/README.md).
        bridge = (
            bridge
            if bridge is not None
            else RosBridge(config.ros_node_name, executor="single_threaded")
        )
        bridge.start()
        recorder = RosRecorder(
            bridge, indexer, bags, config.pose_topic,
            index_hz=config.index_hz, pose_hz=config.pose_hz,
        )  # fmt: skip
    jobs = [
        Job("flush", config.flush_s, indexer.flush),
        Job("retention", config.janitor_s, janitor.enforce),
    ]
    if bags is not None:
        jobs.append(Job("flush_bags", config.flush_s, bags.flush))
    if recorder is not None:
        jobs.append(Job("graph", config.graph_poll_s, recorder.sync))
        jobs.append(Job("pose_catch_up", 1.0 / config.pose_hz, recorder.catch_up))
    worker = Worker(jobs)
    return EpisodicApp(config, memory, build_server(memory), worker, recorder, bridge)


def run() -> None:
    """The process: over stdio, stdout is reserved for JSON-RPC before ROS starts; a bad
    configuration or an unreachable store exits 2 with one line."""
    try:
        settings = transport_settings(os.environ, DEFAULT_PORT)
        config = EpisodicConfig.from_env()
    except ValueError as error:
        refuse_to_start(SERVICE, error)
    wire = reserve_stdout() if settings.transport == "stdio" else None
    configure_logging(SERVICE, level=config.log_level)
    try:
        app = build_app(config)
    except (StoreError, OSError) as error:
        refuse_to_start(SERVICE, error)
    app.worker.start()
    logger.info(
        "episodic_server_starting",
        robot_id=config.robot_id,
        store=config.store,
        data_dir=str(config.data_dir),
        pose_topic=config.pose_topic,
        flush_s=config.flush_s,
        timezone=config.timezone,
        transport=settings.transport,
    )
    try:
        run_server(app.server, DEFAULT_PORT, wire)
    except KeyboardInterrupt:
        pass
    finally:
        app.close()
        logger.info("episodic_server_stopped")


def main() -> None:
    """Console script ``robot-mcp-episodic``: stdio by default, sse / streamable-http by env."""
    run()
