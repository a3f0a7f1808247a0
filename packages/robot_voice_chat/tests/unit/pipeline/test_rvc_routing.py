"""Fast path + routing (spec §5.1): hand-off, mission-active routing, busy, errors."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.llm.base import LLMError, Message, StreamEvent, ToolDefinition
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.settings import ChatConfig
from robot_voice_chat.socket_events import ChatDelta, ChatError, ChatMessage, MissionStarted

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
    h.tools.add("navigation.get_pose", lambda a: {"location": "lobby"})
    fast = FakeLLM([reply("", ("navigation.get_pose", {})), reply("In the lobby.")])
    result = await pipeline_for(h, fast).handle_turn("where are you?")
    assert result.reply == "In the lobby."
    assert fast.requests[1][0][-1].tool_results[0].content == '{"location": "lobby"}'


async def test_fast_path_failure_becomes_a_clear_chat_error(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    result = await pipeline_for(h, FakeLLM([LLMError("recording ran out")])).handle_turn("hi")
    assert result.route == "error"
    said = "Sorry, I can't answer right now: my language model is not answering."
    assert any(isinstance(e, ChatError) and e.message == said for e in h.emitter.events)


async def test_stop_mission_tool_halts_motion(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    fast = FakeLLM([reply("", ("stop_mission", {})), reply("Stopped.")])
    await pipeline_for(h, fast).handle_turn("stop moving")
    assert h.tools.called("navigation.stop_navigation") == [{}]


async def test_the_fast_path_cannot_move_the_robot_outside_a_mission(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    fast = FakeLLM(
        [reply("", ("navigation.navigate_to", {"location": "lab"})), reply("Use a mission.")]
    )
    await pipeline_for(h, fast).handle_turn("drive to the lab")
    offered = {t.name for t in fast.requests[0][1]}
    assert "navigation.navigate_to" not in offered
    assert {"navigation.list_tasks", "perception.prewarm"} <= offered  # reads and non-motion
    assert h.tools.called("navigation.navigate_to") == []
    refusal = fast.requests[1][0][-1].tool_results[0]
    assert refusal.is_error
    assert "start_mission" in refusal.content


class StreamingLLM(FakeLLM):
    """Streams one sentence, then hangs until released (a long reply being spoken)."""

    def __init__(self) -> None:
        super().__init__([])
        self.streaming = asyncio.Event()
        self.release = asyncio.Event()

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        yield StreamEvent(delta="Once upon a time. ")
        self.streaming.set()
        await asyncio.wait_for(self.release.wait(), 10)
        yield StreamEvent(delta="And then a dragon came. ")
        yield StreamEvent(response=reply("Once upon a time. And then a dragon came."))


async def test_a_safety_stop_cancels_a_streaming_fast_path_reply(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    fast = StreamingLLM()
    pipeline = pipeline_for(h, fast)
    turn = asyncio.create_task(pipeline.handle_turn("tell me a long story"))
    await asyncio.wait_for(fast.streaming.wait(), 5)

    await pipeline.stop()
    result = await asyncio.wait_for(turn, 5)
    fast.release.set()

    assert result.route == "stopped"
    assert h.speech.interrupts == 1
    deltas = [e.text for e in h.emitter.events if isinstance(e, ChatDelta)]
    assert deltas == ["Once upon a time. "]
    assert "And then a dragon came." not in h.speech.spoken


class HeldSpeech(FakeSpeechOutput):
    """Speaks a mission's summary only when let go (espeak takes seconds to say it)."""

    def __init__(self) -> None:
        super().__init__()
        self.holding = asyncio.Event()
        self.let_go = asyncio.Event()

    async def speak_sentence(self, sentence: str) -> None:
        if sentence.startswith("The door"):
            self.holding.set()
            await self.let_go.wait()
        await super().speak_sentence(sentence)


async def test_an_instruction_right_after_a_mission_failed_starts_a_new_mission(
    tmp_path: Path,
) -> None:
    """Issue 31: a turn 0.07 s after a failure was routed into the failed mission."""
    failing = reply("", ("finish_mission", {"outcome": "failed", "summary": "The door is shut."}))
    h = make_harness(tmp_path, FakeLLM([failing, reply("", ("wait_for_events", {"reason": "x"}))]))
    speech = HeldSpeech()
    h.executor.speech = h.executor.output.speech = speech
    fast = FakeLLM([reply("", ("start_mission", {"instruction": "Go home", "ack": "On it."}))])
    pipeline = pipeline_for(h, fast)
    first = await h.executor.start("Open the door")
    await async_wait_until(speech.holding.is_set, 5, "the failure being said")
    assert first.state == "failed"

    turn = asyncio.create_task(pipeline.handle_turn("go home"))
    await async_wait_until(lambda: turn.done() or fast.requests, 5, "the turn routed")
    speech.let_go.set()
    result = await asyncio.wait_for(turn, 10)
    assert result.route == "mission_started", result
    assert h.executor.active is not None
    assert h.executor.active.instruction == "Go home"
    await h.executor.shutdown()
