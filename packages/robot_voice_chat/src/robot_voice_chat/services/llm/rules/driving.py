"""Driving: the drive steps of a mission program (drive to a place, follow the server's
suggestions on a failure, one retry where the server advises it, never stop someone else's
drive). Mixed into :class:`~.program.MissionProgram`.
"""

from __future__ import annotations

import json
import re
from typing import Any

from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolDefinition
from robot_voice_chat.services.llm.rules.looking import PREWARM
from robot_voice_chat.services.llm.rules.plain import suggestion_of
from robot_voice_chat.services.llm.rules.recollection import Names
from robot_voice_chat.services.llm.rules.steps import Call, Finished, Outcome, PlanStep, Steps
from robot_voice_chat.services.llm.rules.surface import Failure, detour_legs, has_tool, task_id_of

NAVIGATE = "navigation.navigate_to"
GET_TASK = "navigation.get_task"
CANCEL_TASK = "navigation.cancel_task"


class Driving:
    """The drive steps; :class:`MissionProgram` provides ``act``, ``plan_call``, ``reason``,
    ``_await``, ``_until_resumed``, the plan's steps and the mission's state."""

    tools: list[ToolDefinition]
    steps: list[PlanStep]
    settings: Any
    say: Names
    known: list[str]
    own_drives: set[str]
    terminal: dict[str, Outcome]
    extra_steps: int
    planned: bool

    # -- provided by MissionProgram ---------------------------------------------------------
    def act(self, *calls: Call, text: str = "") -> Steps:
        raise NotImplementedError

    def plan_call(self) -> Call:
        raise NotImplementedError

    def reason(self, content: str) -> str:
        raise NotImplementedError

    def _await(self, task_id: str, reason: str) -> Steps:
        raise NotImplementedError

    def _until_resumed(self, reason: str) -> Steps:
        raise NotImplementedError

    # -- the drives --------------------------------------------------------------------------
    def _drive(self, place: str, step_id: str, prepare: str | None) -> Steps:
        """Drive to ``place``; on a failure try its suggestions in order, then give up."""
        route, tried, retried, legs = [place], set[str](), set[str](), 0
        current, before = step_id, [self.plan_call()] if not self.planned else []
        while route:
            leg = route[0]
            legs += 1
            if legs > self.settings.max_legs:
                raise Finished(
                    "failed", f"I could not reach {self.say(place)} after {legs - 1} drives."
                )
            args: dict[str, Any] = {"step_id": current, "location": leg}
            calls = [*before, Call(NAVIGATE, args)]
            before = []
            if legs == 1 and prepare and has_tool(self.tools, PREWARM) and self.settings.prewarm:
                args["triggers"] = [{"type": "eta_below", "seconds": self.settings.eta_trigger_s}]
                calls.insert(-1, self._prewarm_reaction(prepare))
            result = (yield from self.act(*calls))[-1]
            if result.is_error and HELD_BY_SAFETY_STOP in result.content:  # a stop came first
                yield from self._until_resumed(f"stopped before driving to {self.say(leg)}")
                legs -= 1
                current = self._add_step(current, f"Resume the drive to {self.say(leg)}")
                before = [self.plan_call()]
                continue
            if result.is_error and "BUSY" in result.content:
                result = yield from self._replace_own_drive(leg, args)
            if result.is_error:
                raise Finished(
                    "failed", f"I couldn't drive to {self.say(leg)}: {self.reason(result.content)}."
                )
            task_id = task_id_of(result.content)
            if task_id is None:
                raise Finished(
                    "failed",
                    f"I couldn't drive to {self.say(leg)}: my navigation gave no answer I can use.",
                )
            self.own_drives.add(task_id)
            outcome = yield from self._await(task_id, f"driving to {self.say(leg)}")
            if outcome.kind == "done":
                route.pop(0)
                if route:
                    current = self._add_step(current, f"Drive on to {self.say(route[0])}")
                    before = [self.plan_call()]
                continue
            if outcome.kind == "paused":
                current = self._add_step(current, f"Resume the drive to {self.say(leg)}")
                before = [self.plan_call()]
                continue
            failure = yield from self._failure(task_id, outcome.line)
            detour = next(
                (
                    (s, legs_of)
                    for s in failure.suggestions
                    if s not in tried and (legs_of := detour_legs(s))
                ),
                None,
            )
            if detour is None and failure.retry_suggested and leg not in retried:
                # once per leg: the same drive again is what the server advises, and the base
                # is not busy (its task ended); a second such failure gives up below
                retried.add(leg)
                current = self._add_step(current, f"Retry the drive to {self.say(leg)}")
                said = f"{_capital(self._failure_said(failure))}. I'll try the drive once more."
                before = [self.plan_call(), Call("say", {"text": said})]
                continue
            if detour is None:
                advice = [a for s in failure.suggestions if (a := self._suggestion(s))]
                raise Finished(
                    "failed",
                    f"I couldn't reach {self.say(place)}: {self._failure_said(failure)}."
                    + (f" What could help: {'; '.join(advice)}." if advice else ""),
                )
            suggestion, route = detour
            tried.add(suggestion)
            if route == [leg]:  # "call navigate_to(<the same place>) to resume": a retry
                current = self._add_step(current, f"Resume the drive to {self.say(leg)}")
                said = f"{_capital(self._failure_said(failure))}. I'll drive on to {self.say(leg)}."
                before = [self.plan_call(), Call("say", {"text": said})]
                continue
            current = self._add_step(current, f"Detour via {self.say(route[0])}")
            plan = self._suggestion(suggestion) or f"drive via {self.say(route[0])}"
            said = f"{_capital(self._failure_said(failure))}. I'll {plan}."
            before = [self.plan_call(), Call("say", {"text": said})]

    def _failure_said(self, failure: Failure) -> str:
        """A drive's failure as the robot says it ("the mailroom door is closed")."""
        return self.reason(json.dumps({"error": failure.code, "detail": failure.message}))

    def _suggestion(self, text: str) -> str | None:
        return suggestion_of(text, self.say, self.known)

    def _replace_own_drive(self, leg: str, args: dict[str, Any]) -> Steps:
        """The base is busy. Only a drive of this mission (begun before a planner takeover)
        is cancelled and replaced; a drive someone else started is never stopped here."""
        mine = sorted(t for t in self.own_drives if t not in self.terminal)
        if not mine or not has_tool(self.tools, CANCEL_TASK):
            raise Finished(
                "failed",
                f"I couldn't drive to {self.say(leg)}: the robot is already driving on a task this "
                "mission did not start, and I won't stop someone else's drive. Say stop to "
                "halt it, then ask me again.",
            )
        yield from self.act(*(Call(CANCEL_TASK, {"task_id": t}) for t in mine))
        self.own_drives.difference_update(mine)
        return (yield from self.act(Call(NAVIGATE, args)))[0]

    def _add_step(self, after: str, title: str) -> str:
        """A new drive step right after ``after``: s1 → s1b, s1c, … (ids never reused)."""
        index = next(i for i, s in enumerate(self.steps) if s.id == after)
        self.extra_steps += 1
        new_id = f"{self.steps[0].id}{chr(ord('a') + self.extra_steps)}"
        self.steps.insert(index + 1, PlanStep(new_id, title, NAVIGATE))
        return new_id

    def _prewarm_reaction(self, obj: str) -> Call:
        return Call(
            "register_reaction",
            {
                "event": {
                    "server": "navigation",
                    "type": "trigger_fired",
                    "match": {"type": "eta_below"},
                },
                "call": {
                    "tool": PREWARM,
                    "arguments": {"template": "find_object", "params": {"query": obj}},
                },
            },
        )

    def _failure(self, task_id: str, line: str, get_task: str = GET_TASK) -> Steps:
        if has_tool(self.tools, get_task):
            [result] = yield from self.act(Call(get_task, {"task_id": task_id}))
            failure = Failure.from_task_info(result.content)
            if failure is not None:
                return failure
        match = re.search(r"failed (\S+)[^:]*:\s*(.*?)(?: suggestions: (.*))?$", line)
        if match is None:
            return Failure("FAILED", line, [])
        suggestions = [match[3]] if match[3] else []
        return Failure(match[1], match[2], suggestions, recoverable="(recoverable)" in line)


def _capital(text: str) -> str:
    return text[:1].upper() + text[1:]
