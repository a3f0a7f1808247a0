"""The service plane's credential: where it comes from, what is refused at start, and the
ASGI check in front of an MCP app (issue 27 item 3). The real transports: the integration
test ``test_kit_mcp_server_process.py``."""

from __future__ import annotations

from collections.abc import MutableMapping
from typing import Any

import httpx
import pytest
import structlog

from robot_mcp_kit.caller import PRINCIPAL_SCOPE_KEY
from robot_mcp_kit.service_auth import (
    BearerAuthMiddleware,
    ServiceAuth,
    ServiceAuthError,
    bearer_token,
    service_auth,
)

BRAIN = "b" * 40
OPERATOR = "o" * 40


def test_stdio_needs_no_credential_whatever_the_environment_says() -> None:
    assert service_auth({}, "stdio").enabled is False
    assert service_auth({"MCP_AUTH_TOKEN": "short"}, "stdio").enabled is False


@pytest.mark.parametrize("transport", ["sse", "streamable-http"])
def test_an_http_transport_reads_the_brains_and_the_operators_credentials(
    transport: str,
) -> None:
    auth = service_auth({"MCP_AUTH_TOKEN": BRAIN, "MCP_OPERATOR_TOKEN": OPERATOR}, transport)
    assert auth.identify(BRAIN) == "brain"
    assert auth.identify(OPERATOR) == "operator"
    assert auth.identify(BRAIN[:-1]) is None
    assert auth.identify("") is None
    assert BRAIN not in repr(auth)  # SecretStr: never in a log line or a traceback


@pytest.mark.parametrize(
    ("env", "message"),
    [
        ({}, "MCP_AUTH_TOKEN is not set"),
        ({"MCP_AUTH_TOKEN": "   "}, "MCP_AUTH_TOKEN is not set"),
        ({"MCP_AUTH_TOKEN": "x" * 31}, "31 bytes; at least 32"),
        ({"MCP_AUTH_TOKEN": BRAIN, "MCP_OPERATOR_TOKEN": "y" * 8}, "MCP_OPERATOR_TOKEN is 8"),
        ({"MCP_AUTH_TOKEN": BRAIN, "MCP_OPERATOR_TOKEN": BRAIN}, "must differ"),
        ({"MCP_AUTH": "maybe", "MCP_AUTH_TOKEN": BRAIN}, "'required' or 'off'"),
        ({"MCP_AUTH": "off", "MCP_OPERATOR_TOKEN": OPERATOR}, "MCP_AUTH=off but a token"),
    ],
)
def test_unusable_credential_settings_are_refused_with_one_sentence(
    env: dict[str, str], message: str
) -> None:
    with pytest.raises(ServiceAuthError, match=message) as refused:
        service_auth(env, "sse")
    assert BRAIN not in str(refused.value)


def test_only_an_explicit_off_serves_http_without_credentials() -> None:
    assert service_auth({"MCP_AUTH": "OFF"}, "sse") == ServiceAuth()


@pytest.mark.parametrize(
    ("header", "token"),
    [
        (None, None),
        ("", None),
        ("Bearer", None),
        ("Bearer   ", None),
        ("Basic dXNlcjpwYXNz", None),
        ("Bearer abc", "abc"),
        ("bearer abc ", "abc"),
        ("BEARER  abc", "abc"),
    ],
)
def test_the_bearer_scheme_is_read_case_insensitively(
    header: str | None, token: str | None
) -> None:
    assert bearer_token(header) == token


async def _inner(scope: MutableMapping[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] == "lifespan":
        return
    body = str(scope.get(PRINCIPAL_SCOPE_KEY)).encode()
    await send({"type": "http.response.start", "status": 200, "headers": []})
    await send({"type": "http.response.body", "body": body})


def guarded() -> httpx.AsyncClient:
    auth = service_auth({"MCP_AUTH_TOKEN": BRAIN, "MCP_OPERATOR_TOKEN": OPERATOR}, "sse")
    app = BearerAuthMiddleware(_inner, auth, "navigation")
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://t")


async def test_every_method_and_path_needs_the_credential_and_learns_the_principal() -> None:
    async with guarded() as http:
        for method, path in (("GET", "/sse"), ("POST", "/messages/?session_id=1"), ("GET", "/")):
            refused = await http.request(method, path)
            assert refused.status_code == 401
            assert refused.headers["www-authenticate"] == 'Bearer realm="navigation"'
            brain = await http.request(method, path, headers={"Authorization": f"Bearer {BRAIN}"})
            assert (brain.status_code, brain.text) == (200, "brain")
        operator = await http.get("/sse", headers={"Authorization": f"bearer {OPERATOR}"})
        assert operator.text == "operator"


async def test_a_wrong_credential_is_named_invalid_and_logged_without_any_secret() -> None:
    with structlog.testing.capture_logs() as logs:
        async with guarded() as http:
            answer = await http.get("/sse", headers={"Authorization": f"Bearer {BRAIN}x"})
    assert answer.status_code == 401
    assert answer.headers["www-authenticate"] == (
        'Bearer realm="navigation", error="invalid_token"'
    )
    assert answer.json()["error"] == "invalid_token"
    assert logs == [
        {
            "event": "mcp_auth_rejected",
            "log_level": "warning",
            "server": "navigation",
            "reason": "invalid",
            "method": "GET",
            "path": "/sse",
            "client": "127.0.0.1:123",
        }
    ]
    assert BRAIN not in str(logs)


def test_the_check_refuses_to_guard_with_no_credential() -> None:
    with pytest.raises(ValueError, match="at least one credential"):
        BearerAuthMiddleware(_inner, ServiceAuth(), "navigation")
