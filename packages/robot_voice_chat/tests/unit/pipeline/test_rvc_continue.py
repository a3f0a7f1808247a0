"""'continue' on the fast path (issue 32): with nothing paused it says so and never latches a
stop; while the stop is latched it says an operator must clear it."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language.understand import Understanding
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.settings import ChatConfig


@pytest.fixture(scope="module")
def understanding() -> Understanding:
    return Understanding()


@pytest.mark.parametrize("said", ["continue", "carry on", "go on"])
async def test_continue_with_nothing_paused_says_so_and_never_stops(
    tmp_path: Path, understanding: Understanding, said: str
) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    pipeline = ChatPipeline(llm=RulesChat(understanding), tools=h.tools, executor=h.executor,
                            emitter=h.emitter, speech=h.speech, config=ChatConfig())  # fmt: skip
    result = await pipeline.handle_turn(said)
    assert result.reply.startswith("There's nothing to continue: no mission is paused.")
    assert not h.latch.latched
    assert h.tools.called("navigation.stop_navigation") == []


async def test_continue_while_the_stop_is_latched_says_an_operator_must_clear_it(
    tmp_path: Path, understanding: Understanding
) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    await h.executor.safety_stop("Stop robot (operator UI)", by="alice")
    pipeline = ChatPipeline(llm=RulesChat(understanding), tools=h.tools, executor=h.executor,
                            emitter=h.emitter, speech=h.speech, config=ChatConfig())  # fmt: skip
    result = await pipeline.handle_turn("carry on")
    assert "An operator must press Clear stop" in result.reply
    assert "no paused mission to continue" in result.reply
    assert h.latch.latched
