"""The local stack's approval secrets (issue 35 item 4): memory and episodic check approvals
with the secret the brain signs with, and a test seeding memory signs as the brain does."""

from __future__ import annotations

import hashlib
import hmac
import json
from pathlib import Path

from robot_stack_testing import approval_meta
from robot_stack_testing.stack import (
    load_stack,
    secret_placeholders,
    stack_credentials,
    stack_secrets,
)

STACK = Path(__file__).resolve().parents[4] / "deploy" / "local-stack.yaml"


def test_memory_episodic_and_the_brain_share_one_approval_secret_each() -> None:
    names = stack_credentials(STACK)
    placeholders = {
        **{f"mcp_token_{n}": "t" for n in names},
        **{f"mcp_operator_token_{n}": "o" for n in names},
        **secret_placeholders({n: f"secret-of-{n}" for n in stack_secrets(STACK)}),
    }
    services = {
        s.name: s
        for s in load_stack(STACK, {"python": "py", "root": "r", "var": "v", **placeholders})
    }
    for server in ("memory", "episodic"):
        secret = f"secret-of-approval_{server}"
        assert services[server].env["MCP_APPROVAL_SECRET"] == secret
        assert services["brain"].env[f"{server.upper()}_APPROVAL_SECRET"] == secret
    assert "MCP_APPROVAL_SECRET" not in services["navigation"].env  # no server opts in blindly


def test_the_approval_is_the_documented_hmac_over_the_documented_message() -> None:
    arguments = {"markdown": "# doc", "a": 1}
    meta = approval_meta(
        "s" * 40,
        server="memory",
        tool="save_process",
        arguments=arguments,
        approval_id="ap-1",
        by="bob",
        expires=1_800_000_000,
    )
    entry = meta["robot-stack/approval"]
    digest = hashlib.sha256(b'save_process\n{"a":1,"markdown":"# doc"}').hexdigest()
    assert entry["call"] == digest
    key = hmac.new(b"s" * 40, b"robot-stack approval key v1", hashlib.sha256).digest()
    message = json.dumps(
        ["robot-stack/approval/v1", "memory", "save_process", digest, "ap-1", "bob", 1_800_000_000],
        separators=(",", ":"),
    ).encode()
    assert entry["sig"] == hmac.new(key, message, hashlib.sha256).hexdigest()
    assert set(entry) == {"v", "server", "tool", "call", "approval_id", "by", "expires", "sig"}
