"""ReplayLLM: plays recordings, fails clearly on divergence/exhaustion; the dev recording runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_voice_chat.services.llm.base import Message
from robot_voice_chat.services.llm.replay import (
    ReplayDivergedError,
    ReplayExhaustedError,
    ReplayLLM,
)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "rec.yaml"
    path.write_text(text)
    return path


def user(text: str) -> list[Message]:
    return [Message(role="user", content=text)]


async def test_replay_follows_expectations_optional_entries_and_repeats(tmp_path: Path) -> None:
    llm = ReplayLLM(
        write(
            tmp_path,
            """
name: t
entries:
  - {expect: hello, optional: true, text: hi}
  - {expect: go, tool_calls: [{name: start_mission, arguments: {instruction: x, ack: y}}]}
  - {repeat_until: arrived, text: waiting}
  - {text: done}
""",
        )
    )
    first = await llm.chat(user("go now"))
    assert first.tool_calls[0].name == "start_mission"
    assert (await llm.chat(user("still"))).text == "waiting"
    assert (await llm.chat(user("arrived!"))).text == "done"
    with pytest.raises(ReplayExhaustedError, match="recorded, not generated"):
        await llm.chat(user("more"))


async def test_replay_reports_divergence_instead_of_hanging(tmp_path: Path) -> None:
    llm = ReplayLLM(write(tmp_path, "entries: [{expect: mailroom, text: ok}]"))
    with pytest.raises(ReplayDivergedError, match="expected 'mailroom'"):
        await llm.chat(user("what's the weather"))


async def test_replay_streams_words_then_the_final_response(tmp_path: Path) -> None:
    llm = ReplayLLM(write(tmp_path, "entries: [{text: one two three}]"))
    events = [e async for e in llm.chat_stream(user("x"))]
    assert "".join(e.delta for e in events) == "one two three"
    assert events[-1].response is not None


def test_missing_recording_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="recording not found"):
        ReplayLLM(tmp_path / "nope.yaml")
