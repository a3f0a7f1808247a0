"""Pytest plugin loaded by every package's tests (entry point ``pytest11``).

It makes loopback-only ROS discovery impossible to forget: before any test imports rclpy,
the run gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a ROS domain id of its own, and
child processes inherit both. A Fast DDS profile from the shell (``FASTDDS_`` /
``FASTRTPS_DEFAULT_PROFILES_FILE``, e.g. a robot's, which may name peers or a discovery server)
is replaced by the tests' own, ``fastdds_tests.xml`` (Fast DDS's transports and discovery, a
reliable writer's heartbeat at 100 ms: a lost sample is repaired within about 0.1 s, not 3 s);
a test that wants the local stack's profile takes it from the stack file
(``robot_stack_testing.stack.stack_environment``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_stack_testing.domains import claim_domain_id
from robot_stack_testing.ports import free_tcp_port
from robot_stack_testing.postgres import PostgresServer
from robot_stack_testing.processes import ProcessLauncher

_DOMAIN_OVERRIDE = "ROBOT_TEST_ROS_DOMAIN_ID"
_DROPPED = ("ROS_STATIC_PEERS", "FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
TEST_PROFILE = Path(__file__).with_name("fastdds_tests.xml")
"""Read by Fast DDS 3 (``FASTDDS_DEFAULT_PROFILES_FILE``); Fast DDS 2 spells its element
differently and is left on its defaults."""


def pick_ros_domain_id() -> int:
    """A domain id for this run: the override if given, else a random one (1..100) that no
    other test run on this machine holds (``robot_stack_testing.domains``).

    The environment's own ROS_DOMAIN_ID is ignored on purpose: on a robot it is the live
    robot's domain, which tests must never join.
    """
    override = os.environ.get(_DOMAIN_OVERRIDE)
    if override:
        return int(override)
    return claim_domain_id()


def pytest_configure(config: pytest.Config) -> None:
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(pick_ros_domain_id())
    for name in _DROPPED:
        os.environ.pop(name, None)
    os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(TEST_PROFILE)


def pytest_report_header(config: pytest.Config) -> str:
    return (
        f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']} "
        f"ROS_AUTOMATIC_DISCOVERY_RANGE={os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}"
    )


@pytest.fixture
def ros_domain_id() -> int:
    return int(os.environ["ROS_DOMAIN_ID"])


@pytest.fixture
def launcher(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ProcessLauncher]:
    """Starts OS processes for a test and stops every one of them (by PID) on teardown."""
    processes = ProcessLauncher(tmp_path_factory.mktemp("processes"))
    try:
        yield processes
    finally:
        processes.stop_all()


@pytest.fixture
def tcp_port() -> int:
    return free_tcp_port()


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """A throwaway PostgreSQL for the whole run (started on first use, stopped at the end,
    also when tests failed). Fails, never skips, when the server cannot start."""
    server = PostgresServer.start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def postgres_dsn(postgres_server: PostgresServer) -> str:
    """The DSN of a fresh, empty database on the session's throwaway PostgreSQL."""
    return postgres_server.create_database()
