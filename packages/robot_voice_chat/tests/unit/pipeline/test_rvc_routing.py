"""Fast path + routing (spec §5.1): hand-off, mission-active routing, busy, errors."""

from __future__ import annotations

from pathlib import Path

from robot_stack_testing import async_wait_until
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.llm.base import LLMError
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.settings import ChatConfig
from robot_voice_chat.socket_events import ChatDelta, ChatError, ChatMessage, MissionStarted
from robot_voice_chat.testing import Harness, make_harness

START = ("start_mission", {"instruction": "Fetch the package from the mailroom", "ack": "On it."})


def pipeline_for(h: Harness, fast: FakeLLM) -> ChatPipeline:
    return ChatPipeline(
        llm=fast,
        tools=h.tools,
        executor=h.executor,
        emitter=h.emitter,
        speech=h.speech,
        config=ChatConfig(),
    )


async def test_small_talk_is_answered_by_the_fast_path_and_streamed(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    fast = FakeLLM([reply("Hello there. How can I help?")])
    result = await pipeline_for(h, fast).handle_turn("hi")
    assert result.route == "fast"
    assert result.reply == "Hello there. How can I help?"
    assert any(isinstance(e, ChatDelta) for e in h.emitter.events)
    assert h.speech.spoken == ["Hello there.", "How can I help?"]
    assert [t.name for t in fast.requests[0][1]][:2] == ["start_mission", "stop_mission"]


async def test_start_mission_hands_off_and_later_turns_route_into_the_mission(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            reply("", ("ask_user", {"question": "Which package?"})),
            reply("", ("finish_mission", {"outcome": "succeeded", "summary": "Done."})),
        ]
    )
    h = make_harness(tmp_path, planner)
    fast = FakeLLM([reply("", START)])
    pipeline = pipeline_for(h, fast)
    result = await pipeline.handle_turn("get my package from the mailroom")
    assert result.route == "mission_started"
    assert "On it." in h.speech.spoken
    assert any(isinstance(e, MissionStarted) for e in h.emitter.events)
    await async_wait_until(lambda: h.executor.run and h.executor.run.awaiting_user, 5, "asking")

    routed = await pipeline.handle_turn("the big one")
    await h.executor.wait_idle(5)
    assert routed.route == "mission"
    assert len(fast.requests) == 1  # the fast LLM never saw the mission-time turn
    assert "[user] the big one" in planner.requests[-1][0][-1].content


async def test_a_second_mission_is_rejected_with_a_busy_message(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([reply("", ("wait_for_events", {"reason": "x"}))]))
    fast = FakeLLM([reply("", START, ("start_mission", {"instruction": "Patrol", "ack": "ok"}))])
    result = await pipeline_for(h, fast).handle_turn("fetch and patrol")
    assert result.route == "mission_started"
    replies = [
        e.text for e in h.emitter.events if isinstance(e, ChatMessage) and e.role == "assistant"
    ]
    assert replies[1].startswith("I'm busy with a mission right now (Fetch the package")
    await h.executor.shutdown()


async def test_fast_path_runs_mcp_tools_then_answers(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    h.tools.add("navigation.where_am_i", lambda a: {"location": "lobby"})
    fast = FakeLLM([reply("", ("navigation.where_am_i", {})), reply("In the lobby.")])
    result = await pipeline_for(h, fast).handle_turn("where are you?")
    assert result.reply == "In the lobby."
    assert fast.requests[1][0][-1].tool_results[0].content == '{"location": "lobby"}'


async def test_fast_path_failure_becomes_a_clear_chat_error(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    result = await pipeline_for(h, FakeLLM([LLMError("recording ran out")])).handle_turn("hi")
    assert result.route == "error"
    assert any(
        isinstance(e, ChatError) and "recording ran out" in e.message for e in h.emitter.events
    )


async def test_stop_mission_tool_halts_motion(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    fast = FakeLLM([reply("", ("stop_mission", {})), reply("Stopped.")])
    await pipeline_for(h, fast).handle_turn("stop moving")
    assert h.tools.called("navigation.stop_navigation") == [{}]
