"""The brain's doubles on their own: the simulated office answers like the servers and moves its
things, the harness and a brain life put the brain's composed executor on fakes behind the
real guard, and the recall turn reads the places before its episodic call."""

from __future__ import annotations

from pathlib import Path

from robot_language.recall import WHAT_HAPPENED
from robot_stack_testing.brain.episodic_chat import recall_turn
from robot_stack_testing.brain.harness import NAV_SECRET, harness_tools, make_harness, task_info
from robot_stack_testing.brain.life import brain_life, fake_servers
from robot_stack_testing.brain.office import office
from robot_stack_testing.brain.office_world import DOOR_SUGGESTIONS
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.llm.rules.chat import RulesChat


async def test_the_office_fetches_the_package_past_the_closed_door_and_puts_it_down(
    tmp_path: Path,
) -> None:
    o = office(tmp_path, arm=True)
    mission = await o.run("Please fetch the package from the mailroom and bring it to reception.")
    assert mission.state == "succeeded", mission.summary
    drives = [a["location"] for a in o.tools.called("navigation.navigate_to")]
    assert drives == ["mailroom", "corridor_b", "mailroom", "reception"]
    assert o.world.at == "reception"
    assert o.world.arm.held is None
    assert "yellow package" in o.world.objects["reception"]
    assert "yellow package" not in o.world.objects["mailroom"]


async def test_the_office_door_refuses_the_first_drive_with_the_servers_suggestions(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    mission = await o.run("go to the mailroom")
    assert mission.state == "succeeded", mission.summary
    assert o.world.at == "mailroom"
    assert not o.world.door_closed
    assert DOOR_SUGGESTIONS[1].startswith("use the east entrance")


async def test_the_harness_puts_the_composed_executor_behind_the_guard(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]), supervisor=(0.5, 2.0))
    guarded = h.executor.tools
    assert isinstance(guarded, GuardedToolBackend)
    assert guarded.inner is h.tools
    assert (h.executor.teaching, h.executor.latch) == (h.teaching, h.latch)
    assert h.supervisor is not None
    assert h.executor.supervisor is h.supervisor
    outcome = await guarded.call_tool("navigation.navigate_to", {"location": "kitchen"})
    assert (outcome.is_error, outcome.text) == (False, task_info("nav-1"))
    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}]
    navigation = harness_tools().servers()["navigation"]
    assert navigation.event_secret is not None
    assert navigation.event_secret.get_secret_value() == NAV_SECRET


async def test_a_brain_life_is_assembled_by_the_composition_root_on_the_harness_fakes(
    tmp_path: Path,
) -> None:
    container = brain_life(FakeLLM([]), agent={"memory_server": "", "data_dir": str(tmp_path)})
    servers = fake_servers(container)
    assert servers.has_tool("navigation.navigate_to")
    assert container.executor.tools is container.adapters.tools
    assert container.supervisor is not None
    assert container.teaching is container.executor.teaching


async def test_the_recall_turn_reads_the_places_before_its_episodic_call() -> None:
    response = await recall_turn(RulesChat(), [], "what things did you notice at the front desk?")
    [call] = response.tool_calls
    assert (call.name, call.arguments["place"]) == (WHAT_HAPPENED, "reception")
