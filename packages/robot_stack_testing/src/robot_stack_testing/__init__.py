"""Pytest plugin shared by every package: loopback-only ROS discovery, a per-run domain id,
process fixtures and deadline-bound waits."""

from robot_stack_testing.ports import free_tcp_port, wait_for_tcp_port
from robot_stack_testing.postgres import PostgresServer
from robot_stack_testing.processes import LaunchedProcess, ProcessLauncher
from robot_stack_testing.waiting import async_wait_until, wait_until

__all__ = [
    "LaunchedProcess",
    "PostgresServer",
    "ProcessLauncher",
    "async_wait_until",
    "free_tcp_port",
    "wait_for_tcp_port",
    "wait_until",
]
