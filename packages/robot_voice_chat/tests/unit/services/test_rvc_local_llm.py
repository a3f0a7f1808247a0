"""The local-LLM preset (issue 22): an OpenAI-compatible server on loopback plans and chats,
the embedded understanding layer (rules) takes over when it fails. Requests go through the real
``openai`` SDK to the strict fake, here strict like Ollama (no null content)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robot_stack_testing.brain.fake_wire import openai_responder
from robot_stack_testing.brain.office import office
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_stack_testing.fake_openai import FakeOpenAIApi
from robot_voice_chat.composition import build_adapter, compose_config
from robot_voice_chat.services.llm.base import LLMError, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.chain import PlannerChain
from robot_voice_chat.services.llm.openai_compat import OpenAICompatLLM
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

TOOL = [ToolDefinition(name="navigation.navigate_to", description="drive")]


def drive(body: dict[str, Any]) -> dict[str, Any]:
    if body["messages"][-1]["role"] == "tool":
        return {"content": "Arrived."}
    return {"content": None, "tool_calls": [{"name": "navigation__navigate_to", "arguments": {}}]}


async def test_an_ollama_like_server_rejects_null_content_and_the_preset_sends_text() -> None:
    fake = FakeOpenAIApi(drive, null_content=False)
    with serve_in_thread(fake.app()) as url:
        for empty, rejected in ((None, True), ("", False)):
            llm = OpenAICompatLLM(
                f"{url}/v1", "", "m", max_retries=0, require_key=False, empty_content=empty
            )
            first = await llm.chat([Message(role="user", content="go")], TOOL)
            history = [
                Message(role="user", content="go"),
                first.as_message(),
                Message(
                    role="user",
                    tool_results=[ToolResult(tool_call_id=first.tool_calls[0].id, content="ok")],
                ),
            ]
            if rejected:
                with pytest.raises(LLMError, match="invalid message content type"):
                    await llm.chat(history, TOOL)
            else:
                assert (await llm.chat(history, TOOL)).text == "Arrived."
            await llm.aclose()
    assert fake.rejections == ["invalid message content type: <nil>"]


@pytest.fixture
def local_server(monkeypatch: pytest.MonkeyPatch) -> Iterator[FakeOpenAIApi]:
    # the "local model" plans like the rules planner; the fake checks every request's shape
    fake = FakeOpenAIApi(openai_responder(RulesPlanner()), null_content=False)
    with serve_in_thread(fake.app()) as url:
        monkeypatch.setenv("LOCAL_LLM_BASE_URL", f"{url}/v1")
        monkeypatch.setenv("LOCAL_LLM_MODEL", "qwen2.5:7b-instruct")
        monkeypatch.delenv("LOCAL_LLM_API_KEY", raising=False)
        yield fake


async def test_the_local_llm_preset_runs_a_mission_and_falls_back_to_rules(
    tmp_path: Path, local_server: FakeOpenAIApi
) -> None:
    fake = local_server
    config = compose_config("local_llm")
    planner = build_adapter("llm_planner", config.llm_planner or {})
    assert isinstance(planner, PlannerChain)
    assert planner.name == "chain[openai_compat,rules]"
    o = office(tmp_path)
    o.executor.planner = planner

    mission = await o.run("go to the kitchen and then to reception")
    assert mission.state == "succeeded", mission.summary
    assert [a["location"] for a in o.tools.called("navigation.navigate_to")] == [
        "kitchen",
        "reception",
    ]
    assert not fake.rejections  # every request passed the strict checks
    assert len(fake.requests) >= 4
    body = fake.requests[-1]
    assert body["model"] == "qwen2.5:7b-instruct"
    assert {t["type"] for t in body["tools"]} == {"function"}
    assert "navigation__navigate_to" in {t["function"]["name"] for t in body["tools"]}
    assert any(m.get("tool_calls") for m in body["messages"])  # a tool round trip went back
    assert not planner.degraded

    fake.fail_status = 503  # the local server goes down: the rules planner carries the mission
    mission = await o.run("go to the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert planner.degraded
    assert planner.understanding_label.startswith("rules + embedded matcher (fallback:")
    assert any("local language model" in line for line in o.speech.spoken)
    await planner.aclose()


async def test_the_local_llm_chat_answers_and_the_rules_chat_takes_over_when_it_fails(
    local_server: FakeOpenAIApi,
) -> None:
    fake = local_server
    fake.responder = openai_responder(RulesChat())
    chat = build_adapter("llm", compose_config("local_llm").llm)
    assert isinstance(chat, PlannerChain)
    hello = [Message(role="user", content="hello")]
    assert "offline voice" in (await chat.chat(hello)).text  # answered by the server
    assert len(fake.requests) == 1
    assert not chat.degraded
    fake.fail_status = 500
    assert "offline voice" in (await chat.chat([Message(role="user", content="hi there")])).text
    assert chat.degraded
    assert len(fake.requests) == 1
    await chat.aclose()
