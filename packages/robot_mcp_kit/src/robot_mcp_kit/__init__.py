"""Shared contract of the capability servers: task events, HMAC signing, the event poster
and MCP server plumbing."""

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import (
    KitToolError,
    install_json_tool_errors,
    parse_tool_error,
    run_server,
    tool_error,
)
from robot_mcp_kit.models import (
    SCHEMA_VERSION,
    EventType,
    TaskEvent,
    TaskFailure,
    TaskInfo,
    TaskState,
)
from robot_mcp_kit.outbox import OutboxError, OutboxFullError, OutboxLockedError
from robot_mcp_kit.poster import EventPoster, PosterClosedError
from robot_mcp_kit.signing import (
    HEADER_SERVER,
    HEADER_SIGNATURE,
    HEADER_TIMESTAMP,
    SIGNATURE_PREFIX,
    SignatureError,
    sign,
    signed_headers,
    verify,
    verify_headers,
)
from robot_mcp_kit.tasks import TaskTable

__all__ = [
    "HEADER_SERVER",
    "HEADER_SIGNATURE",
    "HEADER_TIMESTAMP",
    "SCHEMA_VERSION",
    "SIGNATURE_PREFIX",
    "EventPoster",
    "EventType",
    "KitToolError",
    "OutboxError",
    "OutboxFullError",
    "OutboxLockedError",
    "PosterClosedError",
    "SignatureError",
    "TaskEvent",
    "TaskFailure",
    "TaskInfo",
    "TaskState",
    "TaskTable",
    "configure_logging",
    "install_json_tool_errors",
    "parse_tool_error",
    "run_server",
    "sign",
    "signed_headers",
    "tool_error",
    "verify",
    "verify_headers",
]
