"""The robot preset on the whole local stack against the strict local fakes of the Anthropic
Messages API (planner) and the OpenAI-compatible API (Groq fast path): every request the
brain sends must pass the checks the real APIs make. A stand-in model (the rules planner and
rules chat behind the wire) answers as a model would.

    fetch the package from the mailroom and bring it to reception through PlannerChain →
    AnthropicLLM → fake API (the robot goes round the closed door by itself, found, picked,
    carried, placed, seen at reception — read from robot-sim; no rejected request; cost from
    the price table) → then
    the fake API goes down mid mission → the mission finishes on the rules planner, readyz
    reports degraded
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.fake_wire import anthropic_responder, openai_responder
from robot_stack_testing.fake_anthropic import FakeAnthropicApi
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_stack_testing.fake_openai import FakeOpenAIApi
from robot_stack_testing.mission_driver import (
    MissionDriver,
    RunningStack,
    mailroom_stack,
    sim_world,
)
from robot_stack_testing.stack import free_port_overrides
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(480)]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
NOTICE_FRAGMENT = "lost my connection to the cloud planner"
FETCH_REQUEST = "Please fetch the package from the mailroom and bring it to reception."


@pytest.fixture
def fakes() -> Iterator[tuple[FakeAnthropicApi, FakeOpenAIApi, str, str]]:
    anthropic = FakeAnthropicApi(anthropic_responder(RulesPlanner()))
    openai = FakeOpenAIApi(openai_responder(RulesChat()))
    with serve_in_thread(anthropic.app()) as a_url, serve_in_thread(openai.app()) as o_url:
        yield anthropic, openai, a_url, o_url


@pytest.fixture
def stack(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    fakes: tuple[FakeAnthropicApi, FakeOpenAIApi, str, str],
) -> Iterator[RunningStack]:
    _, _, anthropic_url, openai_url = fakes
    for name, value in {
        "ANTHROPIC_API_KEY": "dummy-anthropic-key",
        "ANTHROPIC_BASE_URL": anthropic_url,
        "GROQ_API_KEY": "dummy-groq-key",
        "GROQ_BASE_URL": f"{openai_url}/v1",
        "OPENAI_API_KEY": "dummy-openai-key",
        "OPENAI_BASE_URL": f"{openai_url}/v1",
    }.items():
        monkeypatch.setenv(name, value)
    overrides = {
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "10",
        "brain_deployment": "robot",
        # the robot speaker (espeak-ng) becomes the browser's so the test hears what is said;
        # the operator login (on in the robot preset) has its own tests (test_rvc_auth*.py)
        "brain_config_overrides": "speech_output=socketio auth.enabled=false",
    }
    with mailroom_stack(ROOT, tmp_path / "var", overrides) as running:
        yield running


async def test_the_robot_preset_runs_the_mailroom_mission_through_strict_fake_apis(
    stack: RunningStack, fakes: tuple[FakeAnthropicApi, FakeOpenAIApi, str, str]
) -> None:
    anthropic, openai, _, _ = fakes
    async with MissionDriver(stack.brain_url) as user:
        await user.wait_servers_connected(30.0)
        ready = (await user.http.get("/api/readyz")).json()["data"]
        assert ready["deployment"] == "robot"
        assert ready["planner"] == "chain[anthropic,rules]"
        record = await user.run_mission(FETCH_REQUEST, 150.0)

    assert record.outcome == "succeeded", record.of("mission_finished")
    assert not anthropic.rejections, anthropic.rejections
    assert not openai.rejections, openai.rejections
    assert len(openai.requests) >= 1  # the fast path handed off through the fake Groq
    assert len(anthropic.requests) >= 4  # every planner step went through the fake API
    tools = {t["name"] for t in anthropic.requests[0]["tools"]}
    assert {"navigation__navigate_to", "manipulation__pick", "manipulation__place"} <= tools
    statuses = {s["id"]: s["status"] for s in record.snapshot["steps"]}
    assert set(statuses.values()) == {"succeeded"}, statuses  # robot-sim went round the door
    assert {f.label for f in record.findings()} == {"yellow package"}
    # the package is where robot-sim says it is, not where the summary says
    world = sim_world()
    assert "yellow package" in world["places"]["reception"], world
    assert "yellow package" not in world["places"]["mailroom"], world
    assert record.snapshot["summary"].endswith("I can see it there.")
    usage = record.of("mission_finished")[0]["usage"]
    assert usage["cost_usd"] > 0
    assert usage["cache_read_tokens"] > 0
    assert record.snapshot["usage"]["cost_usd"] == usage["cost_usd"]

    # The cloud goes down while the robot drives: the mission finishes on the rules planner.
    async with MissionDriver(stack.brain_url) as user:
        started = await user.send("go to the kitchen")
        assert started["route"] == "mission_started", started

        def driving() -> bool:
            plans = user.record.of("mission_plan")
            return bool(plans) and plans[-1]["steps"][0]["status"] == "running"

        await async_wait_until(driving, 30, "driving to the kitchen")
        anthropic.fail_status = 529
        degraded = await user.wait_finished(90)
        ready = (await user.http.get("/api/readyz")).json()
    assert degraded.outcome == "succeeded", degraded.of("mission_finished")
    assert any(NOTICE_FRAGMENT in s["text"] for s in degraded.of("speak"))
    assert ready["data"]["planner_state"] == "degraded"
    assert ready["status"] == "degraded"
    assert not anthropic.rejections

    anthropic.fail_status = None  # back online: the next mission plans in the cloud again
    before = len(anthropic.requests)
    async with MissionDriver(stack.brain_url) as user:
        again = await user.run_mission("go to the dock", 90.0)
        ready = (await user.http.get("/api/readyz")).json()["data"]
    assert again.outcome == "succeeded"
    assert len(anthropic.requests) > before
    assert ready["planner_state"] == "ok"
    async with httpx.AsyncClient(base_url=stack.brain_url) as http:
        assert (await http.get("/api/livez")).json() == {"status": "ok"}
