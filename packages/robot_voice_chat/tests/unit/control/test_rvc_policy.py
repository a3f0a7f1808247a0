"""The tool policy: decisions, bounds, defaults from annotations, unknown tools denied."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robot_stack_testing.brain.harness import make_harness, nav_servers
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.policy import (
    OUT_OF_BOUNDS,
    POLICY_DENIED,
    PolicyError,
    ToolPolicy,
)
from robot_voice_chat.services.llm.base import ToolCall
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import CONFIG_DIR

POLICY = """
version: 7
tools:
  navigation.navigate_to:
    decision: allow
    bounds:
      location: {one_of: [kitchen, mailroom]}
  navigation.spin: deny
  skill_control.instantiate_raw_skill: confirm
  perception.get_history:
    bounds:
      seconds: {min: 0, max: 600}
"""
READ_ONLY = {"readOnlyHint": True}
ADDS = {"readOnlyHint": False, "destructiveHint": False}


@pytest.fixture
def policy(tmp_path: Path) -> ToolPolicy:
    path = tmp_path / "policy.yaml"
    path.write_text(POLICY)
    return ToolPolicy.load(path)


def test_the_version_and_digest_identify_the_file(policy: ToolPolicy, tmp_path: Path) -> None:
    assert policy.version == 7
    assert len(policy.digest) == 64
    (tmp_path / "other.yaml").write_text(POLICY + "\n# edited\n")
    assert ToolPolicy.load(tmp_path / "other.yaml").digest != policy.digest


def test_a_listed_decision_wins(policy: ToolPolicy) -> None:
    assert policy.decide("navigation.navigate_to", {"location": "kitchen"}, None, True).action == (
        "allow"
    )
    denied = policy.decide("navigation.spin", {}, READ_ONLY, True)
    assert (denied.action, denied.code) == ("deny", POLICY_DENIED)
    assert policy.decide("skill_control.instantiate_raw_skill", {}, ADDS, False).action == (
        "confirm"
    )


def test_a_location_outside_the_allowed_set_is_out_of_bounds_with_the_bound(
    policy: ToolPolicy,
) -> None:
    decision = policy.decide("navigation.navigate_to", {"location": "roof"}, None, True)
    assert decision.action == "deny"
    assert decision.code == OUT_OF_BOUNDS
    assert "kitchen" in decision.detail
    assert decision.bound == "location: one of ['kitchen', 'mailroom']"


@pytest.mark.parametrize("seconds", [-1, 601, float("nan"), True, "10"])
def test_numbers_outside_the_range_are_out_of_bounds(policy: ToolPolicy, seconds: object) -> None:
    decision = policy.decide("perception.get_history", {"seconds": seconds}, READ_ONLY, False)
    assert decision.code == OUT_OF_BOUNDS
    assert decision.bound == "seconds: a number in [0.0, 600.0]"


def test_numbers_inside_the_range_pass_with_the_annotation_default(policy: ToolPolicy) -> None:
    decision = policy.decide("perception.get_history", {"seconds": 600}, READ_ONLY, False)
    assert (decision.action, decision.source) == ("allow", "annotations")


@pytest.mark.parametrize(
    ("hints", "motion", "action"),
    [
        (READ_ONLY, True, "confirm"),  # a motion server is not trusted to describe itself
        (ADDS, True, "confirm"),  # a motion server's tool
        (None, True, "deny"),
        ({"readOnlyHint": False, "destructiveHint": True}, False, "confirm"),
        ({"readOnlyHint": False}, False, "confirm"),  # MCP default: destructive
        (ADDS, False, "allow"),
        (None, False, "deny"),  # unknown and unannotated
        ({}, False, "confirm"),  # annotations object present but empty: MCP defaults
    ],
)
def test_unlisted_tools_get_their_decision_from_annotations(
    policy: ToolPolicy, hints: dict[str, bool] | None, motion: bool, action: str
) -> None:
    assert policy.decide("other.tool", {}, hints, motion).action == action


def test_an_unknown_unannotated_tool_is_denied_with_why(policy: ToolPolicy) -> None:
    decision = policy.decide("vendor.do_anything", {}, None, False)
    assert decision.code == POLICY_DENIED
    assert "no annotations" in decision.detail


@pytest.mark.parametrize(
    "text",
    [
        "version: 0\n",
        "tools: {}\n",
        "version: 1\ntools: {a.b: maybe}\n",
        "version: [\n",
        "version: 1\ntools: {a.b: {bounds: {x: {}}}}\n",
    ],
)
def test_a_bad_policy_file_is_refused_with_one_clear_error(tmp_path: Path, text: str) -> None:
    (tmp_path / "p.yaml").write_text(text)
    with pytest.raises(PolicyError, match="policy file"):
        ToolPolicy.load(tmp_path / "p.yaml")


def test_a_missing_policy_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="policy file"):
        ToolPolicy.load(tmp_path / "nope.yaml")


def test_the_shipped_policy_loads() -> None:
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    assert policy.version >= 1
    assert policy.decide("skill_control.instantiate_raw_skill", {}, None, False).action == (
        "confirm"
    )


def guarded(policy: ToolPolicy) -> tuple[GuardedToolBackend, FakeToolBackend]:
    fake = FakeToolBackend(nav_servers())
    fake.add("navigation.navigate_to", lambda a: {"ok": True}, location="string")
    fake.add("navigation.spin", lambda a: {"ok": True})
    fake.annotate("navigation.spin", READ_ONLY)
    fake.add("navigation.cancel_task", lambda a: {"ok": True}, task_id="string")
    fake.add("navigation.stop_navigation", lambda a: {"ok": True})
    fake.add("vendor.do_anything", lambda a: {"ok": True})
    return GuardedToolBackend(fake, SafetyLatch(MemoryLatchStore()), policy), fake


async def test_denied_and_out_of_bounds_calls_are_never_sent(policy: ToolPolicy) -> None:
    tools, fake = guarded(policy)
    denied = await tools.call_tool("navigation.spin", {})
    unknown = await tools.call_tool("vendor.do_anything", {})
    outside = await tools.call_tool("navigation.navigate_to", {"location": "roof"})
    inside = await tools.call_tool("navigation.navigate_to", {"location": "kitchen"})

    assert json.loads(denied.text)["error"] == POLICY_DENIED
    assert json.loads(unknown.text)["error"] == POLICY_DENIED
    assert json.loads(outside.text) == {
        "error": OUT_OF_BOUNDS,
        "detail": json.loads(outside.text)["detail"],
        "bound": "location: one of ['kitchen', 'mailroom']",
    }
    assert not inside.is_error
    assert [name for name, _ in fake.calls] == ["navigation.navigate_to"]


async def test_stopping_is_never_gated_even_by_a_policy_that_denies_it(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text(
        "version: 1\ntools: {navigation.cancel_task: deny, navigation.stop_navigation: deny}\n"
    )
    tools, fake = guarded(ToolPolicy.load(path))
    assert not (await tools.call_tool("navigation.cancel_task", {"task_id": "t"})).is_error
    assert not (await tools.call_tool("navigation.stop_navigation", {})).is_error
    assert len(fake.calls) == 2


async def test_a_confirm_tool_without_an_approval_gate_is_refused(policy: ToolPolicy) -> None:
    tools, fake = guarded(policy)
    fake.add("skill_control.instantiate_raw_skill", lambda a: {"ok": True})
    fake.annotate("skill_control.instantiate_raw_skill", ADDS)
    refused = await tools.call_tool("skill_control.instantiate_raw_skill", {"skill": {}})
    assert json.loads(refused.text)["error"] == POLICY_DENIED
    assert "approval" in json.loads(refused.text)["detail"]
    assert fake.called("skill_control.instantiate_raw_skill") == []


def test_reactions_may_only_call_what_is_allowed_without_asking(policy: ToolPolicy) -> None:
    tools, fake = guarded(policy)
    fake.add("skill_control.instantiate_raw_skill", lambda a: {"ok": True})
    fake.annotate("skill_control.instantiate_raw_skill", ADDS)
    assert tools.vet_reaction("navigation.navigate_to", {"location": "kitchen"}) is None
    assert tools.vet_reaction("navigation.stop_navigation", {}) is None
    confirm = tools.vet_reaction("skill_control.instantiate_raw_skill", {"skill": {}})
    outside = tools.vet_reaction("navigation.navigate_to", {"location": "roof"})
    assert confirm is not None
    assert json.loads(confirm)["error"] == POLICY_DENIED
    assert outside is not None
    assert json.loads(outside)["error"] == OUT_OF_BOUNDS


async def test_the_planner_cannot_arm_a_reaction_that_would_need_an_approval(
    policy: ToolPolicy, tmp_path: Path
) -> None:
    h = make_harness(tmp_path, FakeLLM([]), policy=policy)
    h.tools.add("skill_control.instantiate_raw_skill", lambda a: {"ok": True})
    h.tools.annotate("skill_control.instantiate_raw_skill", ADDS)
    await h.executor.start("watch the door")
    run = h.executor.run
    assert run is not None
    event = {"server": "navigation", "type": "trigger_fired"}
    refused = await h.executor.execute(
        run,
        ToolCall(
            id="r1",
            name="register_reaction",
            arguments={
                "event": event,
                "call": {"tool": "skill_control.instantiate_raw_skill", "arguments": {}},
            },
        ),
    )
    allowed = await h.executor.execute(
        run,
        ToolCall(
            id="r2",
            name="register_reaction",
            arguments={"event": event, "call": {"tool": "navigation.stop_navigation"}},
        ),
    )
    assert refused.is_error
    assert json.loads(refused.content)["error"] == POLICY_DENIED
    assert not allowed.is_error
    assert [r.call.tool for r in run.reactions.reactions] == ["navigation.stop_navigation"]
    await h.executor.shutdown()


async def test_the_guard_passes_server_losses_on_to_the_mission(policy: ToolPolicy) -> None:
    """The composition root hands everyone the guard: a server lost must still reach the
    executor's disconnect listener through it (issue 23 item 4)."""
    guard, fake = guarded(policy)
    lost: list[str] = []

    async def on_lost(server: str) -> None:
        lost.append(server)

    guard.add_disconnect_listener(on_lost)
    await fake.disconnected("navigation")
    assert lost == ["navigation"]
