"""Pytest plugin shared by every package: loopback-only ROS discovery, a per-run domain id,
process fixtures and deadline-bound waits."""

from robot_stack_testing.mcp_auth import (
    approval_meta,
    assert_refuses_strangers,
    bearer,
    fresh_token,
    mcp_transport,
)
from robot_stack_testing.ports import free_tcp_port, wait_for_tcp_port
from robot_stack_testing.postgres import PostgresServer
from robot_stack_testing.processes import LaunchedProcess, ProcessLauncher, start_refusal
from robot_stack_testing.stdio import (
    StdioTranscript,
    inspector_tools_list,
    non_protocol_lines,
    run_inspector,
    stdio_session,
)
from robot_stack_testing.waiting import async_wait_until, wait_until

__all__ = [
    "LaunchedProcess",
    "PostgresServer",
    "ProcessLauncher",
    "StdioTranscript",
    "approval_meta",
    "assert_refuses_strangers",
    "async_wait_until",
    "bearer",
    "free_tcp_port",
    "fresh_token",
    "inspector_tools_list",
    "mcp_transport",
    "non_protocol_lines",
    "run_inspector",
    "start_refusal",
    "stdio_session",
    "wait_for_tcp_port",
    "wait_until",
]
