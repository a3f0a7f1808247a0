"""One process life of the brain for tests: the real composition root over fake adapters
(fake planner, fake MCP servers behind the real policy guard), so a test can stop it and
assemble the next life on the same data dir."""

from __future__ import annotations

from typing import Any

from robot_stack_testing.brain.harness import harness_tools
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.services.camera.base import CameraFeed
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.base import LLMProvider
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AppConfig


def brain_life(
    planner: LLMProvider,
    ui: FakeEventEmitter | None = None,
    *,
    tools: ToolBackend | None = None,
    chat: LLMProvider | None = None,
    camera: CameraFeed | None = None,
    **config: Any,
) -> Container:
    """A brain assembled by ``assemble`` with fake adapters (``chat`` default: a fake LLM;
    ``tools``: the harness's fake servers); ``config`` adds or replaces AppConfig sections
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
        llm=chat or FakeLLM([]),
        planner=planner,
        tools=tools if tools is not None else harness_tools(),
        speech_output=FakeSpeechOutput(),
        speech_input=FakeSpeechInput(),
        camera=camera,
    )
    return assemble(app_config, adapters, ui or FakeEventEmitter())


def fake_servers(container: Container) -> FakeToolBackend:
    """The fake MCP servers behind the brain's policy guard."""
    tools = container.adapters.tools
    inner = tools.inner if isinstance(tools, GuardedToolBackend) else tools
    assert isinstance(inner, FakeToolBackend)
    return inner
