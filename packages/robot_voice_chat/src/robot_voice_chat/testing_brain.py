"""One process life of the brain for tests: the real composition root over the fake harness
(fake planner, fake MCP servers behind the real policy guard), on a given data dir, so a test
can stop it and assemble the next life on the same files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robot_voice_chat.composition import Adapters, Container, assemble
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AppConfig
from robot_voice_chat.testing import make_harness


def brain_life(
    tmp_path: Path,
    planner: FakeLLM,
    ui: FakeEventEmitter | None = None,
    **config: Any,
) -> Container:
    """A brain assembled by ``assemble`` with fake adapters; ``config`` adds AppConfig sections
    (e.g. ``control={"policy_file": ...}``). ``ui`` sees what the browser would."""
    app_config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"memory_server": ""},
            **config,
        }
    )
    adapters = Adapters(
        llm=FakeLLM([]),
        planner=planner,
        tools=make_harness(tmp_path, planner).tools,
        speech_output=FakeSpeechOutput(),
        speech_input=FakeSpeechInput(),
    )
    return assemble(app_config, adapters, ui or FakeEventEmitter())


def fake_servers(container: Container) -> FakeToolBackend:
    """The fake MCP servers behind the brain's policy guard."""
    tools = container.adapters.tools
    inner = tools.inner if isinstance(tools, GuardedToolBackend) else tools
    assert isinstance(inner, FakeToolBackend)
    return inner
