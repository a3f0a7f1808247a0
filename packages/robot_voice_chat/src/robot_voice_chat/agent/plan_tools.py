"""The planner's local mission tools (spec §5.3) and the step_id schema injection."""

from __future__ import annotations

import copy
import json
from collections.abc import Awaitable, Callable
from typing import Any

from pydantic import ValidationError

from robot_voice_chat.agent.mission import apply_plan
from robot_voice_chat.agent.reactions import Reaction, ReactionCall
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.services.llm.base import ToolCall, ToolDefinition, ToolResult

STEP_ID = "step_id"
_STEPS_SCHEMA = {
    "type": "array",
    "items": {
        "type": "object",
        "properties": {
            "id": {"type": "string"},
            "title": {"type": "string"},
            "tool": {"type": "string"},
        },
        "required": ["id", "title"],
    },
}


def _tool(
    name: str, description: str, props: dict[str, Any], required: list[str]
) -> ToolDefinition:
    return ToolDefinition(
        name=name,
        description=description,
        parameters={"type": "object", "properties": props, "required": required},
    )


DEFINITIONS: list[ToolDefinition] = [
    _tool(
        "set_plan",
        "Replace the mission plan. Must be your first call.",
        {"steps": _STEPS_SCHEMA},
        ["steps"],
    ),
    _tool(
        "update_plan",
        "Replan: terminal steps keep their status, new ids start pending, removed pending "
        "steps become skipped.",
        {"steps": _STEPS_SCHEMA},
        ["steps"],
    ),
    _tool(
        "mark_step",
        "Set a step's status when no single tool call maps to it.",
        {
            "step_id": {"type": "string"},
            "status": {"type": "string", "enum": ["running", "succeeded", "failed", "skipped"]},
            "detail": {"type": "string"},
        },
        ["step_id", "status"],
    ),
    _tool("say", "Speak a short sentence to the user.", {"text": {"type": "string"}}, ["text"]),
    _tool(
        "register_reaction",
        "Prepare a tool call that fires immediately (no LLM hop) when a matching task event "
        "arrives. match is a subset of the event's payload.trigger.",
        {
            "event": {
                "type": "object",
                "properties": {
                    "server": {"type": "string"},
                    "task_id": {"type": "string"},
                    "type": {"type": "string"},
                    "match": {"type": "object"},
                },
                "required": ["server", "type"],
            },
            "call": {
                "type": "object",
                "properties": {"tool": {"type": "string"}, "arguments": {"type": "object"}},
                "required": ["tool"],
            },
        },
        ["event", "call"],
    ),
    _tool(
        "wait_for_events",
        "Suspend until the next task event, user turn or timeout.",
        {"reason": {"type": "string"}},
        ["reason"],
    ),
    _tool(
        "ask_user",
        "Ask the user a question and wait for the answer.",
        {"question": {"type": "string"}},
        ["question"],
    ),
    _tool(
        "finish_mission",
        "End the mission.",
        {
            "outcome": {"type": "string", "enum": ["succeeded", "failed"]},
            "summary": {"type": "string"},
        },
        ["outcome", "summary"],
    ),
]
LOCAL_TOOLS = frozenset(d.name for d in DEFINITIONS)


def inject_step_id(tools: list[ToolDefinition]) -> list[ToolDefinition]:
    """Each MCP tool gets an optional ``step_id`` property (stripped before the MCP call)."""
    out = []
    for tool in tools:
        schema = copy.deepcopy(tool.parameters)
        schema.setdefault("type", "object")
        schema.setdefault("properties", {})[STEP_ID] = {
            "type": "string",
            "description": "id of the plan step this call belongs to",
        }
        out.append(tool.model_copy(update={"parameters": schema}))
    return out


def strip_step_id(arguments: dict[str, Any]) -> tuple[str | None, dict[str, Any]]:
    args = dict(arguments)
    step_id = args.pop(STEP_ID, None)
    return (str(step_id) if step_id is not None else None), args


class PlanTools:
    """Executes local tools against the run; the executor passes its UI/speech hooks."""

    def __init__(
        self,
        on_plan: Callable[[MissionRun], Awaitable[None]],
        on_say: Callable[[MissionRun, str], Awaitable[None]],
        vet_reaction: Callable[[str, dict[str, Any]], str | None] | None = None,
    ) -> None:
        self._on_plan = on_plan
        self._on_say = on_say
        self._vet_reaction = vet_reaction

    async def call(self, run: MissionRun, call: ToolCall) -> ToolResult:
        handler = getattr(self, f"_{call.name}")
        try:
            if call.name == "register_reaction":
                refused = self._vetted(call.arguments)
                if refused is not None:
                    return ToolResult(tool_call_id=call.id, content=refused, is_error=True)
            text: str = await handler(run, call.arguments)
        except (KeyError, TypeError, ValueError, ValidationError) as exc:
            return ToolResult(
                tool_call_id=call.id, content=f"invalid arguments: {exc}", is_error=True
            )
        return ToolResult(tool_call_id=call.id, content=text)

    def _vetted(self, args: dict[str, Any]) -> str | None:
        if self._vet_reaction is None:
            return None
        call = ReactionCall.model_validate(args["call"])
        return self._vet_reaction(call.tool, call.arguments)

    async def _set_plan(self, run: MissionRun, args: dict[str, Any]) -> str:
        apply_plan(run.mission, list(args["steps"]), replace=True)
        if run.mission.state == "planning":
            run.mission.state = "running"
        await self._on_plan(run)
        return f"plan set: {len(run.mission.steps)} steps"

    async def _update_plan(self, run: MissionRun, args: dict[str, Any]) -> str:
        apply_plan(run.mission, list(args["steps"]), replace=False)
        if run.mission.state in ("planning", "paused"):
            run.mission.state = "running"
        await self._on_plan(run)
        return "plan updated: " + ", ".join(f"{s.id}={s.status}" for s in run.mission.steps)

    async def _mark_step(self, run: MissionRun, args: dict[str, Any]) -> str:
        step = run.mission.step(str(args["step_id"]))
        if step is None:
            raise ValueError(f"no step {args['step_id']!r} in the plan")
        status = args["status"]
        if status not in ("running", "succeeded", "failed", "skipped"):
            raise ValueError(f"bad status {status!r}")
        step.set_status(status, args.get("detail"))
        await self._on_plan(run)
        return f"{step.id} is {step.status}"

    async def _say(self, run: MissionRun, args: dict[str, Any]) -> str:
        await self._on_say(run, str(args["text"]))
        return "said"

    async def _register_reaction(self, run: MissionRun, args: dict[str, Any]) -> str:
        reaction = Reaction.model_validate({"event": args["event"], "call": args["call"]})
        run.reactions.add(reaction)
        return f"reaction registered ({len(run.reactions.reactions)} armed)"

    async def _wait_for_events(self, run: MissionRun, args: dict[str, Any]) -> str:
        run.suspended = True
        return f"waiting ({args.get('reason', '')})"

    async def _ask_user(self, run: MissionRun, args: dict[str, Any]) -> str:
        await self._on_say(run, str(args["question"]))
        run.suspended = True
        run.awaiting_user = True
        return "asked; waiting for the user's answer"

    async def _finish_mission(self, run: MissionRun, args: dict[str, Any]) -> str:
        outcome = args["outcome"]
        if outcome not in ("succeeded", "failed"):
            raise ValueError(f"bad outcome {outcome!r}")
        run.finished = (outcome, str(args.get("summary", "")))
        return json.dumps({"finished": outcome})
