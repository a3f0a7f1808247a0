"""The rules chat (offline fast path) and the template distiller (teaching without keys)."""

from __future__ import annotations

import pytest

from robot_language.commands import parse
from robot_mcp_memory.documents import parse_process
from robot_voice_chat.agent.teaching import render_transcript
from robot_voice_chat.pipeline.fast_tools import FAST_LOCAL_TOOLS
from robot_voice_chat.services.llm.base import Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.distiller import TRANSCRIPT_HEADER, distill
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

TOOLS = [
    *FAST_LOCAL_TOOLS,
    ToolDefinition(name="navigation.navigate_to"),
    ToolDefinition(name="skill_control.instantiate_skill"),
]


def user(text: str) -> list[Message]:
    return [Message(role="system", content="sys"), Message(role="user", content=text)]


@pytest.mark.parametrize(
    ("text", "kind", "obj", "place"),
    [
        ("go to the kitchen", "goto", None, "kitchen"),
        ("Drive to the mailroom and tell me when you arrive", "goto", None, "mailroom"),
        ("find the scissors", "find", "scissors", None),
        ("Could you look for the red mug in the kitchen?", "find", "red mug", "kitchen"),
        ("Please fetch the package from the mailroom.", "fetch", "package", "mailroom"),
        (
            "Fetch the package from the mailroom: drive there and look",
            "fetch",
            "package",
            "mailroom",
        ),
        ("bring me the keys from reception please", "fetch", "keys", "reception"),
        ("what do you see?", "see", None, None),
        ("watch for a person at the door", "watch", "person at the door", None),
        ("dance the tango", "unknown", None, None),
    ],
)
def test_commands_are_understood_as_a_person_types_them(
    text: str, kind: str, obj: str | None, place: str | None
) -> None:
    command = parse(text)
    assert (command.kind, command.obj, command.place) == (kind, obj, place)


async def test_commands_go_to_start_mission_with_an_ack_and_stop_to_stop_mission() -> None:
    chat = RulesChat()
    started = await chat.chat(user("please fetch the package from the mailroom"), TOOLS)
    [call] = started.tool_calls
    assert call.name == "start_mission"
    assert call.arguments == {
        "instruction": "fetch package from mailroom",  # the grammar's words, for the planner
        "ack": "OK, I'll get the package from the mailroom.",
    }
    stop = await chat.chat(user("Stop!"), TOOLS)
    assert [c.name for c in stop.tool_calls] == ["stop_mission"]
    after = [*user("stop"), stop.as_message()]
    told = "I could not reach my navigation, so it could not confirm the stop."
    answer = ToolResult(tool_call_id=stop.tool_calls[0].id, content=told)
    after.append(Message(role="user", tool_results=[answer]))
    assert (await chat.chat(after, TOOLS)).text == told  # what the stop confirmed, no more


async def test_greetings_help_and_anything_else_are_answered_honestly() -> None:
    chat = RulesChat()
    hello = await chat.chat(user("hello"), TOOLS)
    assert hello.text.startswith("Hello! I'm the robot's offline voice")
    assert not hello.tool_calls
    assert "fetch something from a place" in (await chat.chat(user("what can you do?"), TOOLS)).text
    other = await chat.chat(user("tell me a joke"), TOOLS)
    assert other.text.startswith("I can't do that offline: I didn't understand 'tell me a joke'")
    streamed = [e async for e in chat.chat_stream(user("hi"), TOOLS)]
    assert "".join(e.delta for e in streamed[:-1]) == streamed[-1].response.text  # type: ignore[union-attr]


def call(tool: str, result: str = "{}", **arguments: object) -> dict[str, object]:
    return {"kind": "tool_result", "tool": tool, "arguments": arguments, "result": result}


NAV = "navigation.navigate_to"
FAILED = "[task nav-1 navigation.navigate_to] failed DOOR_CLOSED (recoverable): The door is closed."
TRACE = [
    {"kind": "instruction", "instruction": "Please fetch the package from the mailroom."},
    call("set_plan", "plan set"),
    call(NAV, '{"task_id": "nav-1"}', location="mailroom"),
    {"kind": "task_event", "type": "task_failed", "text": FAILED},
    call("navigation.get_task", task_id="nav-1"),
    call(NAV, '{"task_id": "nav-2"}', location="corridor_b"),
    call(NAV, '{"task_id": "nav-3"}', location="mailroom"),
    call("skill_control.instantiate_skill", template="find_object", params={"query": "pkg"}),
    {"kind": "user_turn", "text": "the package is on the left shelf"},
    {"kind": "final", "outcome": "succeeded", "summary": "Found it."},
]


async def test_the_template_distiller_writes_a_process_document_from_the_trace() -> None:
    transcript = render_transcript(TRACE)
    planner = RulesPlanner()
    response = await planner.chat(
        [
            Message(role="system", content="distill"),
            Message(role="user", content=f"{TRANSCRIPT_HEADER}\n{transcript}"),
        ]
    )
    doc = response.text
    assert doc == distill(f"{TRANSCRIPT_HEADER}\n{transcript}")
    assert doc.startswith("---\nid: please-fetch-the-package-from-the-mailroom\n")
    assert 'task_pattern: "please fetch the package from the mailroom."' in doc
    assert "tags: [fetch, package, mailroom]" in doc
    steps = doc.split("## Steps\n", 1)[1].split("## Pitfalls", 1)[0]
    assert steps.splitlines() == [
        '1. navigation.navigate_to({"location":"mailroom"})',
        '2. navigation.navigate_to({"location":"corridor_b"})',
        '3. navigation.navigate_to({"location":"mailroom"})',
        '4. skill_control.instantiate_skill({"template":"find_object","params":{"query":"pkg"}})',
    ]
    assert (
        "- failed DOOR_CLOSED (recoverable): The door is closed. → navigation.navigate_to(" in doc
    )
    assert "## Operator notes\n- the package is on the left shelf" in doc


def test_the_distilled_document_is_valid_for_the_memory_server() -> None:
    doc = distill(f"{TRANSCRIPT_HEADER}\n{render_transcript(TRACE)}")
    parsed = parse_process(doc)  # the memory server's own validation
    assert parsed.id == "please-fetch-the-package-from-the-mailroom"


async def test_where_are_you_with_a_stale_pose_says_the_position_is_not_live() -> None:
    """Issue 27: a base that stopped answering leaves its last pose: never said as a place."""
    chat = RulesChat()
    tools = [*TOOLS, ToolDefinition(name="navigation.get_pose")]
    asked = await chat.chat(user("where are you?"), tools)
    [call] = asked.tool_calls
    assert call.name == "navigation.get_pose"
    pose = (
        '{"x": 4.0, "y": 1.5, "theta": 0, "at_location": "reception", "moving": false, '
        '"stale": true, "pose_note": "no pose from the robot base since it stopped answering '
        '5 s ago: this is where it was last seen"}'
    )
    messages = [*user("where are you?"), asked.as_message()]
    messages.append(
        Message(role="user", tool_results=[ToolResult(tool_call_id=call.id, content=pose)])
    )

    answer = (await chat.chat(messages, tools)).text

    assert answer.startswith("I can't tell where I am right now: no pose from the robot base")
    assert "reception" not in answer
