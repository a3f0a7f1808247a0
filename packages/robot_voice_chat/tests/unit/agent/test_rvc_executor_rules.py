"""The spec §13 executor scenarios with the rules planner instead of a scripted fake: the
same executor, registry, reactions and trace, driven by typed commands over a simulated office
(robot_stack_testing.brain.office_world) that answers like the real servers."""

from __future__ import annotations

import asyncio
import json
import re
from pathlib import Path

import pytest

from robot_language.commands import parse
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import task_info
from robot_stack_testing.brain.office import Office, office
from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.program import MissionProgram
from robot_voice_chat.services.llm.rules.steps import Observation, Program
from robot_voice_chat.socket_events import MissionEventLine, MissionPlan


async def test_go_to_a_place_by_name_resolved_through_list_locations(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("go to the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I'm in the kitchen."
    assert o.tools.called("navigation.list_locations") == [{}]
    assert o.tools.called("navigation.navigate_to") == [{"location": "kitchen"}]
    assert o.statuses(mission) == {"s1": "succeeded", "s2": "succeeded"}
    assert mission.steps[0].task_id == "nav-1"
    assert o.world.at == "kitchen"


async def test_an_alias_resolves_and_an_unknown_place_is_refused_with_the_known_ones(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    mission = await o.run("Drive to the front desk please")
    assert mission.state == "succeeded", mission.summary
    assert o.tools.called("navigation.navigate_to") == [{"location": "reception"}]
    mission = await o.run("go to the moon")
    assert mission.state == "failed"
    assert "I don't know a place called 'moon'" in mission.summary
    assert "kitchen" in mission.summary


async def test_fetch_survives_the_closed_door_by_the_suggested_detour_and_finds_it(
    tmp_path: Path,
) -> None:
    o = office(tmp_path, arm=True)
    mission = await o.run("Please fetch the package from the mailroom.")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == (
        "I picked up the yellow package in the mailroom. I'm holding it; tell me where to bring it."
    )
    assert o.world.arm.held == "yellow package"
    drives = [a["location"] for a in o.tools.called("navigation.navigate_to")]
    assert drives == ["mailroom", "corridor_b", "mailroom"]
    # the failure's suggestions were read from get_task; the one needing a person was skipped
    assert o.tools.called("navigation.get_task") == [{"task_id": "nav-1"}]
    statuses = o.statuses(mission)
    assert statuses["s1"] == "failed"
    assert mission.steps[0].detail.startswith("DOOR_CLOSED")
    assert [statuses[s] for s in ("s1b", "s1c", "s2", "s3", "s4", "s5", "s6", "s7")] == [
        "succeeded"
    ] * 8
    # the eta trigger prewarmed the camera with no planner hop; the prewarm skill was stopped
    assert o.tools.called("skill_control.prewarm_skill") == [
        {"template": "find_object", "params": {"query": "package"}}
    ]
    assert {"skill_id": "prewarm_find_object"} in o.tools.called("skill_control.stop_skill")
    assert "I'll use the east entrance via the corridor b." in o.speech.spoken
    kinds = {r["kind"] for r in await o.trace.read(mission.id)}
    assert {"instruction", "llm_step", "tool_result", "task_event", "reaction", "final"} <= kinds
    plans = [e for e in o.emitter.events if isinstance(e, MissionPlan)]
    assert any(s.status == "running" for p in plans for s in p.steps)


async def test_find_here_and_not_found_elsewhere(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("find the scissors in the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert "scissors" in mission.summary
    mission = await o.run("look for the red mug")  # still in the kitchen
    assert mission.state == "succeeded", mission.summary
    mission = await o.run("find the stapler")
    assert mission.state == "failed"
    assert mission.summary == "I couldn't see the stapler."


@pytest.mark.parametrize(
    ("described", "said"),
    [
        ("The mailroom shelf. On it: a parcel.", "I see the mailroom shelf. On it: a parcel."),
        ("Alice's desk with a green bottle.", "I see Alice's desk with a green bottle."),
    ],
)
async def test_what_i_see_reads_on_as_one_sentence(
    tmp_path: Path, described: str, said: str
) -> None:
    o = office(tmp_path)
    answer = {"skill": "describe_scene", "detections": [],
              "outputs": {"scene_description": {"value": described}}}  # fmt: skip
    o.tools.add("perception.wait_for_result", lambda _args: answer, skill="string",
                timeout_s="number")  # fmt: skip
    mission = await o.run("what do you see?")
    assert mission.summary == said


async def test_what_do_you_see_takes_a_fresh_look_when_the_buffer_is_cold(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    mission = await o.run("what do you see?")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary.startswith("I see an office room")
    assert o.tools.called("skill_control.instantiate_skill")[0]["template"] == "describe_scene"


async def test_watch_for_waits_for_the_watch_event(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("watch for a person at the door")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I saw it: person at the door."
    assert o.statuses(mission)["s2"] == "succeeded"


async def test_anything_else_is_an_honest_offline_refusal(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("dance the tango")
    assert mission.state == "failed"
    assert mission.summary.startswith("I can't do that offline: I didn't understand")
    assert "fetch <thing> from <place>" in mission.summary
    # only the places were read (the request is read against them): nothing moved
    assert [name for name, _ in o.tools.calls] == ["navigation.list_locations"]


async def test_stop_mid_drive_pauses_and_continue_drives_again(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=5.0)
    mission = await o.executor.start("go to the kitchen")
    await async_wait_until(lambda: o.tools.called("navigation.navigate_to"), 5, "driving")
    await o.executor.on_user_turn("stop")
    assert mission.state == "paused"
    assert o.tools.called("navigation.stop_navigation") == [{}]
    o.world.drive_s = 0.05
    await o.executor.latch.clear("operator", "checked")  # an operator clears the stop first
    await o.executor.on_user_turn("continue")
    await o.executor.wait_idle(10)
    assert mission.state == "succeeded", mission.summary
    assert len(o.tools.called("navigation.navigate_to")) == 2
    statuses = o.statuses(mission)
    assert statuses["s1"] == "failed"  # safety stop
    assert statuses["s1b"] == "succeeded"


async def test_stop_then_abort_ends_the_mission(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=5.0)
    mission = await o.executor.start("go to the kitchen")
    await async_wait_until(lambda: o.tools.called("navigation.navigate_to"), 5, "driving")
    await o.executor.on_user_turn("stop")
    await o.executor.on_user_turn("abort")
    await o.executor.wait_idle(10)
    assert mission.state == "failed"
    assert "aborted" in mission.summary


async def test_the_step_budget_still_applies_to_the_rules_planner(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=5.0, max_llm_steps=2)
    mission = await o.run("go to the kitchen")
    assert mission.state == "failed"
    assert "2 planner steps" in mission.summary
    assert o.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]


async def test_the_persons_chat_during_a_drive_does_not_use_up_the_step_budget(
    tmp_path: Path,
) -> None:
    """A plain drive takes 4 planner steps; three chat turns during it wake the planner three
    more times. Those steps are the person's, not a looping planner's: the mission arrives
    (a burst of chat during a drive used up all 40 steps and failed fetches, issue 39)."""
    o = office(tmp_path, drive_s=3.0, max_llm_steps=4)
    mission = await o.executor.start("go to the kitchen")
    await async_wait_until(lambda: o.tools.called("navigation.navigate_to"), 5, "driving")
    run = o.executor.run
    assert run is not None
    for _ in range(3):
        woken = run.llm_steps, len(run.messages)
        await o.executor.on_user_turn("what time is it")
        await async_wait_until(
            lambda w=woken: not run.inbox and len(run.messages) > w[1], 5, "the turn planned"
        )
    await o.executor.wait_idle(10)
    assert mission.state == "succeeded", mission.summary
    assert o.world.at == "kitchen"


def test_a_continue_that_comes_with_the_drives_end_is_used_up_there() -> None:
    """The drive's end (here: cancelled by the stop) and the user's "continue" arrive in one
    planner step: the answer is consumed with that outcome, so the detour drive that follows is
    waited for, not taken for a new pause (which re-sent navigate_to and halted the detour)."""
    tools = [
        ToolDefinition(name=n) for n in ("navigation.navigate_to", "navigation.list_locations")
    ]
    program = MissionProgram(parse("go to the kitchen"), tools).run()
    assert [c.name for c in next(program).calls] == ["set_plan", "navigation.list_locations"]
    places = json.dumps({"locations": [{"name": "kitchen"}]})
    ok = ToolResult(tool_call_id="", content="ok")
    act = program.send(Observation(results=[ok, ToolResult(tool_call_id="", content=places)]))
    assert [c.name for c in act.calls] == ["navigation.navigate_to"]
    drive = ToolResult(tool_call_id="", content=task_info("nav-1"))
    assert [c.name for c in program.send(Observation(results=[drive])).calls] == ["wait_for_events"]
    cancelled = (
        "[task nav-1 navigation.navigate_to] failed CANCELLED (recoverable): cancelled "
        'suggestions: call navigate_to("kitchen") to resume the drive'
    )
    act = program.send(Observation(results=[ok], lines=[cancelled], paused_reply="continue"))
    assert [c.name for c in act.calls] == ["update_plan", "say", "navigation.navigate_to"]
    assert act.calls[-1].arguments["step_id"] == "s1b"
    again = ToolResult(tool_call_id="", content=task_info("nav-2"))
    act = program.send(Observation(results=[ok, ok, again]))
    assert [c.name for c in act.calls] == ["wait_for_events"]


def _program_at_the_drive() -> tuple[Program, ToolResult]:
    tools = [
        ToolDefinition(name=n) for n in ("navigation.navigate_to", "navigation.list_locations")
    ]
    program = MissionProgram(parse("go to the kitchen"), tools).run()
    next(program)
    places = json.dumps({"locations": [{"name": "kitchen"}]})
    ok = ToolResult(tool_call_id="", content="ok")
    act = program.send(Observation(results=[ok, ToolResult(tool_call_id="", content=places)]))
    assert [c.name for c in act.calls] == ["navigation.navigate_to"]
    return program, ok


HELD_RESULT = ToolResult(
    tool_call_id="",
    content=json.dumps({"error": HELD_BY_SAFETY_STOP, "detail": "not sent: a safety stop"}),
    is_error=True,
)


def test_a_drive_held_by_a_stop_is_driven_again_after_continue() -> None:
    program, _ = _program_at_the_drive()
    act = program.send(Observation(results=[HELD_RESULT], paused_reply="continue"))
    assert [c.name for c in act.calls] == ["update_plan", "navigation.navigate_to"]
    assert act.calls[-1].arguments == {"step_id": "s1b", "location": "kitchen"}


def test_a_drive_held_by_a_stop_waits_for_the_answer_and_abort_ends_it() -> None:
    program, ok = _program_at_the_drive()
    act = program.send(Observation(results=[HELD_RESULT]))
    assert [c.name for c in act.calls] == ["wait_for_events"]  # no answer yet: no new drive
    act = program.send(Observation(results=[ok], paused_reply="hmm"))
    assert [c.name for c in act.calls] == ["ask_user"]
    act = program.send(Observation(results=[ok], paused_reply="abort"))
    assert [c.name for c in act.calls] == ["finish_mission"]
    assert act.calls[0].arguments["outcome"] == "failed"


async def test_a_busy_base_is_never_stopped_for_a_drive_this_mission_did_not_start(
    tmp_path: Path,
) -> None:
    o = office(tmp_path, drive_s=30.0)
    o.world.navigate_to({"location": "reception"})  # a drive someone else started
    foreign = o.world.driving
    mission = await o.run("go to the kitchen")
    assert mission.state == "failed"
    assert "already driving on a task this mission did not start" in mission.summary
    assert o.tools.called("navigation.stop_navigation") == []
    assert o.tools.called("navigation.cancel_task") == []
    assert foreign is not None
    assert not foreign.done()
    foreign.cancel()


def test_a_drive_begun_by_the_planner_taken_over_is_replaced_by_cancelling_that_task() -> None:
    tools = [ToolDefinition(name=n) for n in ("navigation.navigate_to", "navigation.cancel_task")]
    program = MissionProgram(parse("go to the kitchen"), tools, resumed=True, own_drives={"nav-7"})
    busy = '{"error": "NAVIGATION_BUSY", "detail": "a navigation is running"}'
    drive = program._drive("kitchen", "s1", prepare=None)
    first = next(drive)
    assert [c.name for c in first.calls][-1] == "navigation.navigate_to"
    answers = [ToolResult(tool_call_id="a", content="ok")] * (len(first.calls) - 1)
    answers.append(ToolResult(tool_call_id="b", content=busy, is_error=True))
    second = drive.send(Observation(results=answers))
    assert [(c.name, c.arguments) for c in second.calls] == [
        ("navigation.cancel_task", {"task_id": "nav-7"})
    ]
    third = drive.send(Observation(results=[ToolResult(tool_call_id="c", content="{}")]))
    assert [c.name for c in third.calls] == ["navigation.navigate_to"]


async def restart_navigation(o: Office) -> None:
    """The navigation server restarts: its drive and its task table are gone; the brain's
    reconciliation turns the lost task into SERVER_RESTARTED (recoverable, "retry")."""
    await async_wait_until(lambda: o.executor.registry.live(), 5, "driving")
    assert o.world.driving is not None
    o.world.driving.cancel()
    o.world.tasks.clear()
    await o.executor.reconcile("navigation")


async def test_a_drive_lost_to_a_server_restart_is_retried_once(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=0.5)
    running = asyncio.create_task(o.run("go to the kitchen"))
    await restart_navigation(o)
    mission = await running
    assert mission.state == "succeeded", mission.summary
    assert [a["location"] for a in o.tools.called("navigation.navigate_to")] == [
        "kitchen",
        "kitchen",
    ]
    assert mission.steps[0].detail.startswith("SERVER_RESTARTED")
    said = [e.text for e in o.emitter.events if isinstance(e, MissionEventLine) and e.kind == "say"]
    assert any("try the drive once more" in s for s in said)


async def test_a_second_server_restart_is_not_retried_again(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=0.5)
    running = asyncio.create_task(o.run("go to the kitchen"))
    await restart_navigation(o)
    await async_wait_until(
        lambda: len(o.tools.called("navigation.navigate_to")) == 2, 5, "the retry"
    )
    await restart_navigation(o)
    mission = await running
    assert mission.state == "failed"
    assert mission.summary == (
        "I couldn't reach the kitchen: my navigation restarted and lost track of the task."
    )
    assert len(o.tools.called("navigation.navigate_to")) == 2


def lines_said(o: Office) -> list[str]:
    return [e.text for e in o.emitter.events if isinstance(e, MissionEventLine) and e.kind == "say"]


async def test_a_mission_is_told_when_its_server_dies_and_gives_up_if_it_stays_away(
    tmp_path: Path,
) -> None:
    """Issue 23 item 4: navigation killed mid-drive and not restarted."""
    o = office(tmp_path, drive_s=30.0, wakeup_timeout_s=0.5)
    o.tools.add_disconnect_listener(o.executor.on_server_lost)
    running = asyncio.create_task(o.run("go to the kitchen", timeout_s=20))
    await async_wait_until(lambda: o.executor.registry.live(), 5, "driving")
    steps_before = o.executor.run.llm_steps if o.executor.run else 0
    assert o.world.driving is not None
    o.world.driving.cancel()  # the server and its drive are gone
    await o.tools.disconnected("navigation")

    mission = o.executor.active
    assert mission is not None
    assert mission.steps[0].detail == "navigation server unreachable: waiting for it to come back"
    assert any("I lost contact with my navigation" in s for s in lines_said(o))
    await async_wait_until(
        lambda: o.executor.run is None or o.executor.run.llm_steps > steps_before,
        5,
        "the planner woken",
    )
    mission = await running
    assert mission.state == "failed"
    assert "lost contact with my navigation while driving to the kitchen" in (mission.summary)


async def test_a_server_that_comes_back_restarted_gets_the_drive_again(tmp_path: Path) -> None:
    o = office(tmp_path, drive_s=0.5, wakeup_timeout_s=30.0)
    o.tools.add_disconnect_listener(o.executor.on_server_lost)
    o.tools.add_connect_listener(o.executor.reconcile)
    running = asyncio.create_task(o.run("go to the kitchen"))
    await async_wait_until(lambda: o.executor.registry.live(), 5, "driving")
    assert o.world.driving is not None
    o.world.driving.cancel()
    o.world.tasks.clear()
    await o.tools.disconnected("navigation")
    await o.tools.reconnected("navigation")  # restarted: nav-1 unknown → SERVER_RESTARTED
    mission = await running
    assert mission.state == "succeeded", mission.summary
    assert len(o.tools.called("navigation.navigate_to")) == 2


async def test_a_dead_vision_node_is_reported_as_unavailable_not_as_nothing_seen(
    tmp_path: Path,
) -> None:
    """Issue 23 item 5: the vision node killed during "find the scissors"."""
    o = office(tmp_path)
    o.tools.add(
        "perception.wait_for_result",
        lambda a: (_ for _ in ()).throw(
            ValueError('{"error": "timeout", "detail": "no result for skill find_object"}')
        ),
        skill="string",
        timeout_s="number",
    )
    o.tools.add(
        "skill_control.list_running_skills",
        lambda a: (_ for _ in ()).throw(
            ValueError('{"error": "service_unavailable", "detail": "the vision node is down"}')
        ),
    )
    mission = await o.run("find the scissors in the kitchen")
    assert mission.state == "failed"
    assert mission.summary == (
        "My camera system isn't answering, so I can't look for the scissors right now."
    )
    assert o.tools.called("skill_control.stop_skill")  # the skill is still stopped


async def test_a_running_vision_node_that_saw_nothing_still_says_so(tmp_path: Path) -> None:
    o = office(tmp_path)
    o.tools.add(
        "perception.wait_for_result",
        lambda a: (_ for _ in ()).throw(ValueError('{"error": "timeout", "detail": "none"}')),
        skill="string",
        timeout_s="number",
    )
    o.tools.add("skill_control.list_running_skills", lambda a: {"skills": []})
    mission = await o.run("find the scissors in the kitchen")
    assert mission.summary == "I couldn't see the scissors in the kitchen."


async def test_a_sentence_that_failed_while_navigation_was_down_works_once_it_is_back(
    tmp_path: Path,
) -> None:
    """Issue 31: the same words after the cause is gone are planned afresh, not replayed."""
    o = office(tmp_path)
    o.tools.states["navigation"] = "disconnected"  # killed: its tools are gone
    failed = await o.run("go to the kitchen")
    assert failed.state == "failed"
    assert "navigation" in failed.summary
    await o.tools.reconnected("navigation")
    mission = await o.run("go to the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert o.world.at == "kitchen"
    assert o.tools.called("navigation.navigate_to") == [{"location": "kitchen"}]


@pytest.mark.parametrize(
    ("reason", "why"),
    [
        ("network", "the cloud vision service is unreachable"),
        ("budget", "my cloud vision budget is spent for now"),
        ("something_new", "the vision model failed"),  # an unknown reason is not said raw
    ],
)
async def test_a_find_that_cannot_see_says_so_and_never_that_the_thing_is_not_there(
    tmp_path: Path, reason: str, why: str
) -> None:
    """Issue 30: the vision node could not look at all (no fallback grounder) — the buffer's
    result carries cannot_see; the robot says it cannot see, in plain words."""
    o = office(tmp_path)
    answer = {"skill": "find_object", "detections": [], "stale": True,
              "cannot_see": True, "cannot_see_reason": reason}  # fmt: skip
    o.tools.add("perception.wait_for_result", lambda _args: answer, skill="string",
                timeout_s="number")  # fmt: skip
    mission = await o.run("find the stapler")
    assert mission.state == "failed"
    assert mission.summary == (
        f"I can't see right now ({why}), so I don't know whether the stapler is there."
    )
    assert not _codes_ids_or_tool_names(mission.summary)
    assert o.tools.called("skill_control.stop_skill")  # the skill is still stopped


def _codes_ids_or_tool_names(said: str) -> list[str]:
    """What the robot's words must not carry: snake_case ids and reasons, ERROR_CODES, dotted
    tool names, task ids (nav-1a2b)."""
    patterns = (r"\b\w+_\w+\b", r"\b[A-Z]{2,}\b", r"\b[a-z_]+\.[a-z_]+\b", r"\b[a-z]+-\w*\d\w*\b")
    return [hit for pattern in patterns for hit in re.findall(pattern, said)]


def test_the_plan_names_places_as_people_say_them_never_by_map_id() -> None:
    """The steps are titled before the map is read ("Drive to the desk_alice"); once the live
    places are known the plan is sent again with their names, before the first drive."""
    tools = [
        ToolDefinition(name=n) for n in ("navigation.navigate_to", "navigation.list_locations")
    ]
    program = MissionProgram(parse("go to desk_alice"), tools).run()
    first = next(program)
    assert [c.name for c in first.calls] == ["set_plan", "navigation.list_locations"]
    places = json.dumps(
        {"locations": [{"name": "desk_alice", "description": "Alice's desk in the open plan."}]}
    )
    ok = ToolResult(tool_call_id="", content="ok")
    act = program.send(Observation(results=[ok, ToolResult(tool_call_id="", content=places)]))
    assert [c.name for c in act.calls] == ["update_plan"]
    titles = [s["title"] for s in act.calls[0].arguments["steps"]]
    assert titles[0] == "Drive to Alice's desk", titles
    assert not any("desk_alice" in t for t in titles)
    act = program.send(Observation(results=[ok]))
    assert [c.name for c in act.calls] == ["navigation.navigate_to"]
    assert act.calls[0].arguments["location"] == "desk_alice"
