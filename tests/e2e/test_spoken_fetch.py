"""A person next to the robot asks for the package by voice (issue 36 item 4), on the whole local
stack with the brain on the dev preset as shipped (rules, no keys, the on-board recognizer):
robot-sim-say speaks the fetch request on /audio_stamped, robot-audio-listener posts it to the
brain, the brain reads the motion command back ("Did you say …?"), the person says it again (a
repeat confirms), and the package arrives at reception in robot-sim's world
(``robot-sim-world --show``), not in the brain's report."""

from __future__ import annotations

import asyncio
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import (
    SAYS_AT_MOST,
    MissionDriver,
    fresh_secret,
    say_on_microphone,
    sim_world,
    spoken_turn_outcomes,
    stack_env,
)
from robot_stack_testing.stack import LocalStack, free_port_overrides, local_stack, stack_defaults

pytestmark = [
    pytest.mark.slow,
    pytest.mark.ros,
    pytest.mark.timeout(420),
    pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed"),
]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
PACKAGE = "yellow package"
REQUEST = "fetch the package from the mailroom and bring it to reception"


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[LocalStack, str]]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "brain_config_overrides": "",  # the dev preset as shipped: rules, on-board speech
    }
    var = tmp_path_factory.mktemp("spoken-fetch") / "var"
    with local_stack(ROOT, var, stack_env(fresh_secret()), overrides=placeholders) as services:
        yield services, f"http://127.0.0.1:{placeholders['brain_port']}"


async def test_a_spoken_fetch_request_brings_the_package(
    stack: tuple[LocalStack, str],
) -> None:
    services, brain = stack
    sim_world("mailroom", "cardboard box", PACKAGE)
    sim_world("reception", "blue folder")
    listener = services["audio_listener"]
    async with MissionDriver(brain) as user:

        async def connected() -> bool:
            states = (await user.http.get("/api/readyz")).json()["data"]["mcp_servers"]
            wanted = ("navigation", "manipulation", "skill_control", "perception")
            return all(states.get(s) == "connected" for s in wanted)

        await async_wait_until(connected, 120, "the servers connected", 0.5)

        def outcomes() -> list[str]:
            return spoken_turn_outcomes(services["brain"].log())

        # as a person does: say it again when the robot did not catch it or read it back
        for says in range(1, SAYS_AT_MOST + 1):
            await say_on_microphone(REQUEST)
            await async_wait_until(lambda n=says: len(outcomes()) >= n, 60, f"say {says}", 0.2)
            if outcomes()[says - 1] == "acted":
                break
        else:
            raise AssertionError(f"not acted on after {SAYS_AT_MOST} says: {outcomes()}")
        assert '"utterance_sent"' in listener.log()  # it came through the robot's microphone

        async def arrived() -> bool:
            world = await asyncio.to_thread(sim_world)
            return PACKAGE in world["places"]["reception"]

        await async_wait_until(arrived, 240, "the package at reception", 2.0)
    world = sim_world()
    assert PACKAGE not in world["places"]["mailroom"]
    assert world["held"] is None
