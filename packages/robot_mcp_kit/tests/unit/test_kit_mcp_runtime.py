from __future__ import annotations

import json

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.server.mcpserver.exceptions import ToolError

from robot_mcp_kit.mcp_runtime import (
    install_json_tool_errors,
    parse_tool_error,
    tool_error,
    transport_settings,
)
from robot_stack_testing.kit.tool_calls import tool_answer


def build_server() -> MCPServer:
    server = MCPServer("kit-test")

    @server.tool()
    async def open_door(door: str) -> dict[str, str]:
        """Opens a door unless it is locked."""
        if door == "mailroom":
            raise tool_error("DOOR_LOCKED", f"the {door} door is locked")
        if door == "crash":
            raise RuntimeError("secret internals")
        return {"opened": door}

    return server


def text_of(result: object) -> str:
    content = result.content  # type: ignore[attr-defined]
    assert len(content) == 1
    text: str = content[0].text
    return text


def test_tool_error_is_an_sdk_tool_error_whose_text_is_json() -> None:
    err = tool_error("DOOR_LOCKED", "locked — try later")
    assert isinstance(err, ToolError)
    assert json.loads(str(err)) == {"error": "DOOR_LOCKED", "detail": "locked — try later"}
    assert (err.code, err.detail) == ("DOOR_LOCKED", "locked — try later")


async def test_a_tool_error_reaches_the_client_as_an_error_result_with_json_text() -> None:
    server = install_json_tool_errors(build_server())
    async with Client(server) as client:
        failed = await client.call_tool("open_door", {"door": "mailroom"})
        ok = await client.call_tool("open_door", {"door": "kitchen"})

    assert failed.is_error is True
    assert json.loads(text_of(failed)) == {
        "error": "DOOR_LOCKED",
        "detail": "the mailroom door is locked",
    }
    assert ok.is_error is False
    assert json.loads(text_of(ok)) == {"opened": "kitchen"}


async def test_crashes_and_bad_arguments_also_become_json_errors_without_internals() -> None:
    server = install_json_tool_errors(build_server())
    install_json_tool_errors(server)  # idempotent
    async with Client(server) as client:
        crashed = await client.call_tool("open_door", {"door": "crash"})
        invalid = await client.call_tool("open_door", {"door": ["not", "a", "string"]})

    crash = json.loads(text_of(crashed))
    assert crashed.is_error
    assert crash["error"] == "tool_error"
    assert "secret internals" not in crash["detail"]
    assert invalid.is_error
    assert json.loads(text_of(invalid))["error"] == "tool_error"


async def test_without_the_middleware_the_error_is_still_parseable() -> None:
    async with Client(build_server()) as client:
        failed = await client.call_tool("open_door", {"door": "mailroom"})
    assert failed.is_error
    assert text_of(failed).startswith("Error executing tool open_door: ")
    assert parse_tool_error(text_of(failed)) == {
        "error": "DOOR_LOCKED",
        "detail": "the mailroom door is locked",
    }


def test_parse_tool_error_returns_none_for_other_texts() -> None:
    assert parse_tool_error("plain failure") is None
    assert parse_tool_error('{"error": 3, "detail": "x"}') is None
    assert parse_tool_error("[1, 2]") is None


def test_transport_settings_default_to_stdio_on_loopback() -> None:
    settings = transport_settings({}, 9101)
    assert (settings.transport, settings.host, settings.port) == ("stdio", "127.0.0.1", 9101)


def test_transport_settings_read_the_environment() -> None:
    env = {
        "MCP_TRANSPORT": "Streamable-HTTP",
        "MCP_HOST": "0.0.0.0",
        "MCP_PORT": "9300",
        "MCP_AUTH_TOKEN": "t" * 32,
    }
    settings = transport_settings(env, 9101)
    assert (settings.transport, settings.host, settings.port) == (
        "streamable-http",
        "0.0.0.0",
        9300,
    )
    assert settings.auth is not None
    assert settings.auth.identify("t" * 32) == "brain"


@pytest.mark.parametrize(
    ("env", "message"),
    [
        ({"MCP_TRANSPORT": "websocket"}, "MCP_TRANSPORT"),
        ({"MCP_PORT": "http"}, "integer"),
        ({"MCP_PORT": "70000"}, "1..65535"),
        ({"MCP_TRANSPORT": "sse"}, "MCP_AUTH_TOKEN is not set"),
    ],
)
def test_transport_settings_reject_bad_values_clearly(env: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        transport_settings(env, 9101)


async def test_tool_answer_reads_structured_content_and_errors() -> None:
    server = install_json_tool_errors(build_server())
    async with Client(server) as client:
        assert await tool_answer(client, "open_door", {"door": "kitchen"}) == {"opened": "kitchen"}
        failed = await tool_answer(client, "open_door", {"door": "mailroom"})
    assert failed == {"_error": {"error": "DOOR_LOCKED", "detail": "the mailroom door is locked"}}
