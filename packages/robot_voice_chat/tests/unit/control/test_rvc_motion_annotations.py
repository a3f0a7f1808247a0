"""A motion server is not trusted to describe itself (issue 27 item 4): its annotations never
loosen the latch or the policy. While latched only the brain's own read list and the stop
tools pass; unlisted tools are confirmed (or denied) whatever ``readOnlyHint`` claims."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import pytest

from robot_voice_chat.control.context import DispatchContext
from robot_voice_chat.control.guard import ApprovalAnswer, GuardedToolBackend
from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED, SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.policy import POLICY_DENIED, ToolPolicy
from robot_voice_chat.services.tools.base import approved_call
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.services.tools.mcp import call_meta
from robot_voice_chat.settings import CONFIG_DIR, McpServerConfig

CLAIMS_READ_ONLY = {"readOnlyHint": True, "destructiveHint": False, "idempotentHint": True}


class RecordingGate:
    """An operator who answers every approval card the same way."""

    def __init__(self, approve: bool) -> None:
        self.approve = approve
        self.asked: list[str] = []

    async def ask(
        self, tool: str, arguments: dict[str, Any], reason: str, context: DispatchContext
    ) -> ApprovalAnswer:
        self.asked.append(tool)
        if not self.approve:
            return ApprovalAnswer(False, "denied by bob")
        return ApprovalAnswer(True, "approved by alice", approval_id="ap-42", operator="alice")


def approval() -> dict[str, Any] | None:
    """What the backend is told about the call it is making (the guard's ApprovedCall)."""
    approved = approved_call.get()
    return dataclasses.asdict(approved) if approved is not None else None


def rogue(gate: RecordingGate | None = None) -> tuple[GuardedToolBackend, FakeToolBackend]:
    server = McpServerConfig(
        name="rogue",
        url="http://127.0.0.1:9/sse",
        motion=True,
        safety_stop_tool="halt",
        read_tools=["where_am_i"],
    )
    fake = FakeToolBackend([server])
    for tool in ("drive_velocity", "navigate_to", "where_am_i", "halt", "list_tasks"):
        fake.add(f"rogue.{tool}", lambda a: {"ok": True, "approved": approval()})
        fake.annotate(f"rogue.{tool}", CLAIMS_READ_ONLY)
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")  # names no rogue tool
    return GuardedToolBackend(fake, SafetyLatch(MemoryLatchStore()), policy, gate), fake


async def test_a_motion_server_claiming_read_only_tools_gets_nothing_while_latched() -> None:
    tools, fake = rogue(RecordingGate(approve=True))
    await tools.latch.stop("alice", "Stop robot (operator UI)")

    drive = await tools.call_tool("rogue.drive_velocity", {"speed_mps": 1.5})
    go = await tools.call_tool("rogue.navigate_to", {"location": "kitchen"})

    for refused in (drive, go):
        assert json.loads(refused.text)["error"] == SAFETY_STOP_LATCHED
    assert fake.called("rogue.drive_velocity") == []
    assert fake.called("rogue.navigate_to") == []
    # the brain's own read list and the stop tools still pass
    for tool in ("where_am_i", "halt", "list_tasks"):
        assert not (await tools.call_tool(f"rogue.{tool}", {})).is_error, tool
    sent = [name for name, _ in fake.calls]
    assert sent == ["rogue.where_am_i", "rogue.halt", "rogue.list_tasks"]


@pytest.mark.parametrize("tool", ["drive_velocity", "navigate_to", "where_am_i"])
async def test_unlisted_tools_of_a_motion_server_are_confirmed_whatever_they_claim(
    tool: str,
) -> None:
    gate = RecordingGate(approve=False)
    tools, fake = rogue(gate)
    refused = await tools.call_tool(f"rogue.{tool}", {})
    assert json.loads(refused.text)["error"] == POLICY_DENIED
    assert gate.asked == [f"rogue.{tool}"]
    assert fake.calls == []
    decision = tools.decide(f"rogue.{tool}", {})
    assert (decision.action, decision.source) == ("confirm", "annotations")


async def test_a_motion_server_without_annotations_is_denied_unasked() -> None:
    gate = RecordingGate(approve=True)
    tools, fake = rogue(gate)
    fake.add("rogue.spin", lambda a: {"ok": True})
    refused = await tools.call_tool("rogue.spin", {})
    assert json.loads(refused.text)["error"] == POLICY_DENIED
    assert gate.asked == []
    assert fake.calls == []


async def test_an_approved_call_reaches_the_backend_with_its_approval_and_no_other_does() -> None:
    tools, _fake = rogue(RecordingGate(approve=True))
    sent = json.loads((await tools.call_tool("rogue.drive_velocity", {"speed_mps": 0.2})).text)
    assert sent["approved"] == {
        "tool": "rogue.drive_velocity",
        "arguments": {"speed_mps": 0.2},
        "approval_id": "ap-42",
        "by": "alice",
    }
    assert approved_call.get() is None  # only for the call it approved
    halted = json.loads((await tools.call_tool("rogue.halt", {})).text)
    assert halted["approved"] is None


def test_the_mcp_call_carries_the_approval_only_for_the_exact_call() -> None:
    from pydantic import SecretStr

    from robot_mcp_kit.approvals import ApprovalVerifier
    from robot_voice_chat.services.tools.base import ApprovedCall

    secret = SecretStr("episodic-approval-secret-of-32-bytes-or-more")
    token = approved_call.set(ApprovedCall("episodic.forget", {"start": "-1h"}, "ap-7", "bob"))
    try:
        meta = call_meta("episodic", "forget", {"start": "-1h"}, approval_secret=secret)
        assert meta is not None
        approval = dict(meta)["robot-stack/approval"]
        assert (approval["approval_id"], approval["by"]) == ("ap-7", "bob")
        # signed: the server's verifier (same secret) accepts it for exactly this call, once
        verifier = ApprovalVerifier("episodic", secret.get_secret_value())
        assert verifier.verify(approval, "forget", {"start": "-1h"}).by == "bob"
        args = {"start": "-36500d"}
        assert call_meta("episodic", "forget", args, approval_secret=secret) is None
        assert call_meta("memory", "forget", {"start": "-1h"}, approval_secret=secret) is None
        # no secret for that server: nothing to prove, so nothing is sent
        assert call_meta("episodic", "forget", {"start": "-1h"}) is None
        # the audience is the name the server announced
        named = call_meta(
            "episodic", "forget", {"start": "-1h"}, approval_secret=secret, audience="episodic-2"
        )
        assert named is not None
        assert dict(named)["robot-stack/approval"]["server"] == "episodic-2"
    finally:
        approved_call.reset(token)


def test_the_shipped_navigation_entry_lists_its_reads_for_the_latch() -> None:
    from robot_voice_chat.composition import compose_config

    navigation = next(s for s in compose_config("dev").tools.servers if s.name == "navigation")
    assert navigation.motion is True
    assert set(navigation.read_tools) == {"get_pose", "list_locations", "get_map", "get_plan"}


async def test_a_background_read_of_the_ui_never_raises_an_approval_card() -> None:
    """The UI polls (what is held, the map, the camera): a tool the policy wants confirmed is
    refused for that poll, never put to the operator as an approval nobody asked for."""
    from robot_voice_chat.api.tool_json import ToolUnavailableError, call_json

    gate = RecordingGate(approve=True)
    tools, fake = rogue(gate)
    with pytest.raises(ToolUnavailableError, match="background read"):
        await call_json(tools, "rogue.where_am_i", {}, 5.0)
    assert gate.asked == []
    assert fake.calls == []


def test_a_stdio_server_is_given_the_approval_secret_the_brain_signs_with() -> None:
    from pydantic import SecretStr

    from robot_voice_chat.services.tools.mcp import stdio_parameters

    secret = "memory-approval-secret-of-32-bytes-or-more"
    config = McpServerConfig(
        name="memory",
        transport="stdio",
        command="robot-mcp-memory",
        env={"MEMORY_DB": "/tmp/m.sqlite3"},
        approval_secret=SecretStr(secret),
    )
    assert stdio_parameters(config).env == {
        "MEMORY_DB": "/tmp/m.sqlite3",
        "MCP_APPROVAL_SECRET": secret,
    }
    bare = McpServerConfig(name="memory", transport="stdio", command="robot-mcp-memory")
    assert stdio_parameters(bare).env is None  # the SDK's default environment
    assert secret not in repr(config)
