"""A mission as a deterministic program over the live tools, written as a generator: it
yields the tool calls of one planner step (:class:`Act`) and receives what came back
(:class:`Observation`: the results of those calls, the event and user lines since).

    set_plan + list_locations → navigate_to (eta trigger + prewarm reaction) → wait for the
    task → on task_failed read get_task's suggestions and drive the first detour that needs
    no person → find_object → wait_for_result → stop_skill → finish_mission
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from robot_voice_chat.robot_words import service_name
from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolDefinition
from robot_voice_chat.services.llm.rules.carry import (
    GET_HELD,
    NO_ARM,
    PICK,
    PLACE,
    RELEASE,
    Carrying,
)
from robot_voice_chat.services.llm.rules.commands import Command
from robot_voice_chat.services.llm.rules.plain import reason_of, suggestion_of
from robot_voice_chat.services.llm.rules.recollection import (
    Names,
    by_id,
    last_sightings_sentence,
    names_of,
)
from robot_voice_chat.services.llm.rules.steps import (
    Act,
    Call,
    Finished,
    Observation,
    Outcome,
    PlanStep,
    Program,
    Steps,
)
from robot_voice_chat.services.llm.rules.surface import (
    Failure,
    Locations,
    as_json,
    detour_legs,
    has_tool,
    task_id_of,
)
from robot_voice_chat.services.llm.understanding.places import PlaceIndex, located

NAVIGATE = "navigation.navigate_to"
LIST_LOCATIONS = "navigation.list_locations"
GET_TASK = "navigation.get_task"
CANCEL_TASK = "navigation.cancel_task"
INSTANTIATE = "skill_control.instantiate_skill"
PREWARM = "skill_control.prewarm_skill"
STOP_SKILL = "skill_control.stop_skill"
LIST_SKILLS = "skill_control.list_running_skills"
WAIT_RESULT = "perception.wait_for_result"
WHAT_DO_YOU_SEE = "perception.what_do_you_see"
WHAT_HAPPENED = "episodic.what_happened"
# the historical mode of "what do you see" (seed 000 §8): the newest sightings of the last day
LAST_SIGHTINGS = {"start": "-1d", "kinds": ["sightings"], "max_items": 3}
UNDERSTOOD = (
    "go to <place>, find <thing> [in <place>], what do you see, watch for <thing>, "
    "fetch <thing> from <place> [and bring it to <place>], pick up <thing>, put it down "
    "[at <place>], hand it over"
)
TASK_EVENT = re.compile(
    r"^\[task (?P<id>\S+) [\w.\-]+\] (?P<kind>done|failed|watch_event)\b(?P<rest>.*)"
)
USER_TURN = "[user] "  # a mid-mission turn as the executor posts it
_SERVER_LOST = re.compile(r"^\[server (?P<server>\S+)\] unreachable: tasks (?P<ids>.+?) cannot")
_SERVER_BACK = re.compile(r"^\[server (?P<server>\S+)\] back\b")
_CONTINUE = ("continue", "yes", "go on", "resume", "carry on", "proceed", "ok", "okay", "sure")
_ABORT = ("abort", "no", "cancel", "give up", "forget it", "never mind", "quit")


@dataclass
class Settings:
    prewarm: bool = True
    eta_trigger_s: float = 10.0
    find_timeout_s: float = 20.0
    max_legs: int = 6


class MissionProgram(Carrying):
    """One mission's program; ``resumed`` = taking over a conversation another planner began,
    ``own_drives`` = the drives that conversation started and that may still run."""

    def __init__(
        self,
        command: Command | list[Command],
        tools: list[ToolDefinition],
        settings: Settings | None = None,
        resumed: bool = False,
        refusal: str | None = None,
        listed: str | None = None,
        own_drives: set[str] | None = None,
    ) -> None:
        # a request of several legs (drive, then drive; fetch, then deliver) runs them in order
        self.legs = command if isinstance(command, list) else [command]
        self.command = self.legs[0]
        self.refusal = refusal
        self.listed = listed  # list_locations' answer when the planner already has it
        self.tools = tools
        self.settings = settings or Settings()
        self.resumed = resumed
        self.prefix = "r" if resumed else "s"
        self.steps: list[PlanStep] = []
        self.terminal: dict[str, Outcome] = {}
        self.pause_reply: str | None = None
        self.reactions_fired: list[str] = []
        self.planned = False
        self.extra_steps = 0
        # drives this mission started (also those of a planner it took over from)
        self.own_drives: set[str] = set(own_drives or ())
        self.user_turns: list[str] = []  # what people said mid-mission, not answered yet
        self.doing = ""  # what the robot is busy with, for those answers
        self.told_busy: str | None = None  # the activity the busy answer was said for
        self.say: Names = by_id  # how sentences say the map's places (the live list's names)
        self.known: list[str] = []  # the map's place ids (said by name inside server text)
        self.unreachable: dict[str, set[str]] = {}  # server → its tasks we can't hear from
        self.timeouts = 0  # "[timeout] still waiting" wakeups seen
        self.seen: Any = None  # the last look's result (its detections carry mask_refs)
        self.holding: str | None = None  # what the arm's server said it holds

    # --- plumbing --------------------------------------------------------------------------
    def run(self) -> Program:
        try:
            yield from self._main()
            raise Finished("failed", "I stopped without reaching the goal.")  # not reached
        except Finished as end:
            calls = [Call("finish_mission", {"outcome": end.outcome, "summary": end.summary})]
            tell = next((s for s in self.steps if s.tool is None), None)
            if tell is not None and end.outcome == "succeeded":
                calls.insert(0, Call("mark_step", {"step_id": tell.id, "status": "succeeded"}))
            while True:
                yield Act(calls)

    def act(self, *calls: Call, text: str = "") -> Steps:
        """One planner step; a person who spoke since the last one is answered with it (a
        brief ``say``, spec §5.1), and the callers see the results of their own calls only."""
        answer = []
        if self.user_turns and self.told_busy != self.activity():
            # said once per activity: every turn already got its own answer on screen, and
            # twenty messages must not make the robot say the same thing twenty times
            answer = [Call("say", {"text": self.busy_answer()})]
            self.told_busy = self.activity()
        self.user_turns.clear()
        observation: Observation = yield Act([*answer, *calls], text)
        self.absorb(observation)
        return observation.results[len(answer) :]

    def activity(self) -> str:
        return self.doing or f"working on: {self.command.text.strip()}"

    def busy_answer(self) -> str:
        heard = self.user_turns[-1]
        doing = self.activity()
        return (
            f"I heard {heard!r}, but I'm busy {doing}. Offline I can't change a running "
            "mission: say stop to halt me, then give me the new task."
        )

    def absorb(self, observation: Observation) -> None:
        for line in observation.lines:
            match = TASK_EVENT.match(line.strip())
            if match is not None:
                self.terminal[match["id"]] = Outcome(match["kind"], line.strip())
            elif line.startswith(USER_TURN):
                self.user_turns.append(line.removeprefix(USER_TURN).strip())
            elif (lost := _SERVER_LOST.match(line.strip())) is not None:
                self.unreachable[lost["server"]] = set(lost["ids"].split(", "))
            elif (back := _SERVER_BACK.match(line.strip())) is not None:
                self.unreachable.pop(back["server"], None)
            elif line.startswith("[timeout]"):
                self.timeouts += 1
            elif line.startswith("[reaction]"):
                self.reactions_fired.append(line)
        if observation.paused_reply is not None:
            self.pause_reply = observation.paused_reply

    def step_id(self, n: int) -> str:
        return f"{self.prefix}{n}"

    def plan_call(self) -> Call:
        name = "update_plan" if self.planned or self.resumed else "set_plan"
        self.planned = True
        steps = [
            {"id": s.id, "title": s.title, **({"tool": s.tool} if s.tool else {})}
            for s in self.steps
        ]
        return Call(name, {"steps": steps})

    def needs(self, *names: str) -> None:
        missing = [n for n in names if not has_tool(self.tools, n)]
        if missing:
            server = missing[0].split(".")[0]
            raise Finished(
                "failed", f"I can't do that right now: my {service_name(server)} is not connected."
            )

    def reason(self, content: str) -> str:
        """A tool error as the robot says it (codes and tool names stay in the step)."""
        return reason_of(content, self.say, self.known)

    # --- the missions ------------------------------------------------------------------------
    def _main(self) -> Steps:
        c = self.command
        if self.refusal is not None:
            raise Finished("failed", self.refusal)
        if len(self.legs) > 1 and any(leg.kind in ("see", "watch") for leg in self.legs):
            raise Finished(
                "failed",
                "Offline I chain drives, searches and fetches; ask me to look or watch on its own.",
            )
        if c.kind == "unknown":
            raise Finished(
                "failed",
                f"I can't do that offline: I didn't understand {c.text.strip()!r}. "
                f"Offline I understand: {UNDERSTOOD}.",
            )
        if c.kind == "see":
            yield from self._see()
            return
        if c.kind == "watch":
            yield from self._watch(c.obj or "something")
            return
        yield from self._run_legs()

    def _run_legs(self) -> Steps:
        """Every leg in order: drive to its place, look for its object, pick it up, bring it
        on, put it down and look that it is there. All places are resolved before the first
        drive, so a request is never cut short halfway."""
        carry = self.can_carry()
        plan: list[tuple[Command, dict[str, str]]] = []
        at: str | None = None  # where the legs before this one leave the robot
        for leg in self.legs:
            ids: dict[str, str] = {}
            takes = leg.kind in ("fetch", "pick") and leg.obj is not None
            if leg.kind in ("pick", "put", "release") and not carry:
                raise Finished("failed", f"{NO_ARM}, so I can't pick things up or put them down.")
            if leg.place is not None and not _already_there(leg, at):
                self.needs(NAVIGATE, LIST_LOCATIONS)
                ids["drive"] = self.add_step(f"Drive to the {leg.place}", NAVIGATE)
            if leg.obj is not None and leg.kind in ("find", "fetch", "pick"):
                self.needs(INSTANTIATE, WAIT_RESULT, STOP_SKILL)
                ids["look"] = self.add_look(leg.obj, f"Look for the {leg.obj}")
            if takes and carry:
                ids["pick"] = self.add_step(f"Pick up the {leg.obj}", PICK)
                ids["held"] = self.add_step("Check what I hold", GET_HELD)
            if leg.to is not None and (carry or not takes):
                self.needs(NAVIGATE, LIST_LOCATIONS)
                ids["deliver"] = self.add_step(f"Bring it to the {leg.to}", NAVIGATE)
            if leg.kind == "release":
                ids["release"] = self.add_step("Hand it over", RELEASE)
            elif leg.kind == "put" or (takes and carry and leg.to is not None):
                what = f"the {leg.obj}" if leg.obj else "it"
                ids["put"] = self.add_step(f"Put {what} down", PLACE)
                ids["confirm"] = self.add_look(leg.obj or "it", "Look that it is there")
            plan.append((leg, ids))
            at = leg.to or leg.place or at
        self.add_step("Tell the user", None)
        names: dict[str, str] = {}
        spoken: Names = by_id
        phrases = [p for leg in self.legs for p in (leg.place, leg.to) if p is not None]
        if phrases and self.listed is not None:
            names, spoken = self._places(self.listed, phrases)  # the plan goes with the 1st drive
        elif phrases:
            results = yield from self.act(self.plan_call(), Call(LIST_LOCATIONS))
            names, spoken = self._places(results[1].content, phrases)
        else:
            yield from self.act(self.plan_call())
        said: list[str] = []
        place: str | None = None
        for leg, ids in plan:
            if "drive" in ids and leg.place is not None:
                place = names[leg.place]
                yield from self._drive(place, ids["drive"], prepare=leg.obj)
            where: str = f" {located(spoken(place))}" if place else ""
            if "look" in ids and leg.obj is not None:
                if not self.planned:
                    yield from self.act(self.plan_call())
                found = yield from self._look_for(leg.obj, ids["look"])
                if not found:
                    missed = f"I couldn't see the {leg.obj}{where if leg.place else ''}."
                    raise Finished("failed", " ".join([*said, missed]))
                if leg.kind in ("fetch", "pick") and "pick" not in ids:
                    said.append(
                        f"I found the {leg.obj}{where}: {found}. But I can't carry it: "
                        f"{NO_ARM}. It is still{where}."
                    )
                    raise Finished("failed", " ".join(said))
                if "pick" not in ids:
                    said.append(f"I found the {leg.obj}{where if leg.place else ''}: {found}.")
            if "pick" in ids and leg.obj is not None:
                held: str = yield from self._pick(leg.obj, where, ids["pick"], ids["held"])
                self.holding = held
                said.append(f"I picked up the {held}{where}.")
            if "deliver" in ids and leg.to is not None:
                place = names[leg.to]
                yield from self._drive(place, ids["deliver"], prepare=None)
                where = f" {located(spoken(place))}"
                if not self.holding:
                    said.append(f"I'm {located(spoken(place))}.")
            thing: str | None = self.holding or leg.obj
            if ({"put", "release"} & set(ids)) and self.holding is None:
                thing = yield from self._held_now()  # a put on its own: what is in the gripper?
                if thing is None:
                    raise Finished("failed", " ".join([*said, "I'm not holding anything."]))
            phrase = f"the {thing}" if thing else "it"
            if "release" in ids:
                yield from self._put(phrase.removeprefix("the "), "release", ids["release"], where)
                said.append(f"I let go of {phrase}{where}.")
                self.holding = None
            if "put" in ids:
                if not self.planned:
                    yield from self.act(self.plan_call())
                yield from self._put(phrase.removeprefix("the "), "place", ids["put"], where)
                self.holding = None
                if not thing or not (yield from self._confirm(thing, ids["confirm"])):
                    said.append(
                        f"I put {phrase} down{where}, but the camera doesn't show it there, "
                        "so I can't confirm it arrived."
                    )
                    raise Finished("failed", " ".join(said))
                verb = "brought" if leg.kind == "fetch" else "put"
                said.append(f"I {verb} {phrase} {'to' if verb == 'brought' else 'down'}"
                            f"{(' ' + spoken(place)) if verb == 'brought' and place else where}: "
                            "I can see it there.")  # fmt: skip
            elif "pick" in ids and "deliver" not in ids and "release" not in ids:
                said.append("I'm holding it; tell me where to bring it.")
            bare_drive = not ({"look", "put", "release", "deliver"} & set(ids))
            if bare_drive and place is not None:
                said.append(f"I'm {located(spoken(place))}.")
        raise Finished("succeeded", " ".join(said))

    def _places(self, listed: str, phrases: list[str]) -> tuple[dict[str, str], Names]:
        """Each phrase's place on the live map (unknown or ambiguous ends before any drive),
        and how sentences say the map's places."""
        locations = Locations.from_result(listed)
        index = PlaceIndex.from_result(listed)
        self.say, self.known = names_of(index), locations.known()
        names: dict[str, str] = {}
        for phrase in phrases:
            exact = locations.resolve(phrase)
            match = index.resolve(phrase)
            if exact is None and not match.sure:
                known = ", ".join(self.say(n) for n in self.known) or "none"
                if match.names:
                    options = " or ".join(self.say(n) for n in match.names)
                    known = f"did you mean {options}? Tell me again with the place"
                    raise Finished("failed", f"I'm not sure which place {phrase!r} is: {known}.")
                raise Finished(
                    "failed", f"I don't know a place called {phrase!r}. I know: {known}."
                )
            names[phrase] = exact or match.names[0]
        return names, names_of(index)

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
                current = self._add_step(current, f"Resume the drive to the {leg}")
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
                    current = self._add_step(current, f"Drive on to the {route[0]}")
                    before = [self.plan_call()]
                continue
            if outcome.kind == "paused":
                current = self._add_step(current, f"Resume the drive to the {leg}")
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
                current = self._add_step(current, f"Retry the drive to the {leg}")
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
            current = self._add_step(current, f"Detour via the {route[0]}")
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

    def _await(self, task_id: str, reason: str) -> Steps:
        self.doing = reason
        timeouts = self.timeouts
        while True:
            lost = next((srv for srv, ids in self.unreachable.items() if task_id in ids), None)
            if lost is None:
                timeouts = self.timeouts
            elif self.timeouts > timeouts:  # a whole wakeup period and it is still gone
                raise Finished(
                    "failed",
                    f"I lost contact with my {service_name(lost)} while {reason} and it has not "
                    "come back, so I can't tell or control what that task does; I stopped "
                    "waiting. Check that service, then ask me again.",
                )
            # the answer is used up here even when the task ended meanwhile: left pending,
            # it would read as a new pause at the next wait and halt the next drive
            answer = self._take_pause_answer()
            if answer == "continue":
                return self.terminal.get(task_id, Outcome("paused"))
            if answer == "unclear":
                yield from self.act(Call("ask_user", {"question": "Should I continue or abort?"}))
            elif task_id in self.terminal:
                return self.terminal[task_id]
            else:
                yield from self.act(Call("wait_for_events", {"reason": reason}))

    def _until_resumed(self, reason: str) -> Steps:
        """Wait for the person's answer to a safety stop: continue returns, abort ends."""
        while (answer := self._take_pause_answer()) != "continue":
            if answer == "unclear":
                yield from self.act(Call("ask_user", {"question": "Should I continue or abort?"}))
            else:
                yield from self.act(Call("wait_for_events", {"reason": reason}))

    def _take_pause_answer(self) -> str | None:
        """The person's answer to a stop, used up: continue | unclear | None (none yet);
        an abort ends the mission."""
        if self.pause_reply is None:
            return None
        reply, self.pause_reply = self.pause_reply.lower(), None
        if any(re.search(rf"\b{w}\b", reply) for w in _ABORT):
            raise Finished("failed", "Stopped by the user; mission aborted.")
        if any(re.search(rf"\b{w}\b", reply) for w in _CONTINUE):
            return "continue"
        return "unclear"

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

    def _look_for(self, obj: str, step_id: str) -> Steps:
        """instantiate find_object → wait_for_result → stop; the labels found ('' if none)."""
        self.doing = f"looking for the {obj}"
        index = next(i for i, s in enumerate(self.steps) if s.id == step_id)
        read, stop = self.steps[index + 1].id, self.steps[index + 2].id
        [started] = yield from self.act(
            Call(
                INSTANTIATE,
                {"step_id": step_id, "template": "find_object", "params": {"query": obj}},
            )
        )
        if started.is_error:
            raise Finished(
                "failed", f"I couldn't start looking for the {obj}: {self.reason(started.content)}."
            )
        data = as_json(started.content)
        skill = (
            str(data.get("skill_id", "find_object")) if isinstance(data, dict) else "find_object"
        )
        [seen] = yield from self.act(
            Call(
                WAIT_RESULT,
                {"step_id": read, "skill": skill, "timeout_s": self.settings.find_timeout_s},
            )
        )
        down = (yield from self._vision_down()) if seen.is_error else None
        stops = [Call(STOP_SKILL, {"step_id": stop, "skill_id": skill})]
        if any(PREWARM in line for line in self.reactions_fired):
            stops.append(Call(STOP_SKILL, {"skill_id": "prewarm_find_object"}))
        yield from self.act(*stops)
        if down is not None:  # not "I couldn't see it": the camera could not look at all
            raise Finished(
                "failed", f"I couldn't look for the {obj}: my camera is unavailable ({down})."
            )
        if seen.is_error:
            return ""
        looked = as_json(seen.content)
        if isinstance(looked, dict) and looked.get("cannot_see"):  # never "it isn't there"
            raise Finished(
                "failed",
                f"I can't see right now ({_cannot_see(looked.get('cannot_see_reason'))}), "
                f"so I don't know whether the {obj} is there.",
            )
        self.seen = looked  # the arm takes its detection from here
        return _labels(looked)

    def _vision_down(self) -> Steps:
        """After a wait with no result: is the vision node reachable at all? The reason if
        not (skill_control cannot reach it), else None (it runs: nothing was seen)."""
        if not has_tool(self.tools, LIST_SKILLS):
            return None
        [listed] = yield from self.act(Call(LIST_SKILLS))
        return self.reason(listed.content) if listed.is_error else None

    def _remembered(self) -> Steps:
        """What the robot saw last, when and where (the episodic memory), or "" without it."""
        if not has_tool(self.tools, WHAT_HAPPENED):
            return ""
        recall = self.step_id(6)
        self.steps.insert(max(0, len(self.steps) - 1), PlanStep(recall, "Recall what I saw last",
                                                              WHAT_HAPPENED))  # fmt: skip
        [remembered] = (
            yield from self.act(
                self.plan_call(), Call(WHAT_HAPPENED, {**LAST_SIGHTINGS, "step_id": recall})
            )
        )[1:]
        if remembered.is_error:
            return ""
        places = PlaceIndex.from_result(self.listed) if self.listed is not None else None
        return last_sightings_sentence(remembered.content, names_of(places))

    def _see(self) -> Steps:
        if not has_tool(self.tools, WHAT_DO_YOU_SEE) and has_tool(self.tools, WHAT_HAPPENED):
            self.steps = [PlanStep(self.step_id(2), "Tell the user", None)]
            memory = yield from self._remembered()
            raise Finished(
                "succeeded", f"I can't look right now (perception is not connected). {memory}"
            )
        self.needs(WHAT_DO_YOU_SEE)
        self.doing = "looking around"
        self.steps = [
            PlanStep(self.step_id(1), "Check what the camera sees", WHAT_DO_YOU_SEE),
            PlanStep(self.step_id(2), "Tell the user", None),
        ]
        [view] = (
            yield from self.act(
                self.plan_call(), Call(WHAT_DO_YOU_SEE, {"step_id": self.step_id(1)})
            )
        )[1:]
        data = as_json(view.content) if not view.is_error else None
        text = _scene_text(data) if isinstance(data, dict) and data.get("mode") == "warm" else ""
        if not text and has_tool(self.tools, INSTANTIATE) and has_tool(self.tools, WAIT_RESULT):
            look, read, stop = (self.step_id(n) for n in (3, 4, 5))
            self.steps[1:1] = [
                PlanStep(look, "Take a fresh look", INSTANTIATE),
                PlanStep(read, "Read the description", WAIT_RESULT),
                PlanStep(stop, "Stop the vision skill", STOP_SKILL),
            ]
            [started] = (
                yield from self.act(
                    self.plan_call(),
                    Call(
                        INSTANTIATE, {"step_id": look, "template": "describe_scene", "params": {}}
                    ),
                )
            )[1:]
            if not started.is_error:
                info = as_json(started.content)
                skill = (
                    str(info.get("skill_id", "describe_scene"))
                    if isinstance(info, dict)
                    else "describe_scene"
                )
                [fresh] = yield from self.act(
                    Call(
                        WAIT_RESULT,
                        {
                            "step_id": read,
                            "skill": skill,
                            "timeout_s": self.settings.find_timeout_s,
                        },
                    )
                )
                yield from self.act(Call(STOP_SKILL, {"step_id": stop, "skill_id": skill}))
                fresh_data = as_json(fresh.content) if not fresh.is_error else None
                text = _scene_text(fresh_data) if isinstance(fresh_data, dict) else ""
                down = (yield from self._vision_down()) if fresh.is_error else None
                if down is not None:
                    memory = yield from self._remembered()
                    raise Finished(
                        "failed",
                        f"I can't look right now: my camera is unavailable ({down}). " + memory,
                    )
        if not text:
            memory = yield from self._remembered()
            if memory:
                raise Finished("succeeded", f"I see nothing new right now. {memory}")
            raise Finished(
                "failed", "I can't tell what I see right now: the camera gave me nothing."
            )
        raise Finished("succeeded", f"I see {_mid_sentence(text)}")

    def _watch(self, thing: str) -> Steps:
        self.needs(INSTANTIATE)
        start, wait, stop = (self.step_id(n) for n in (1, 2, 3))
        self.steps = [
            PlanStep(start, f"Start watching for {thing}", INSTANTIATE),
            PlanStep(wait, f"Wait until {thing}", None),
            PlanStep(stop, "Stop the watcher", STOP_SKILL),
            PlanStep(self.step_id(4), "Tell the user", None),
        ]
        [started] = (
            yield from self.act(
                self.plan_call(),
                Call(
                    INSTANTIATE,
                    {"step_id": start, "template": "watch_for", "params": {"condition": thing}},
                ),
            )
        )[1:]
        task_id = None if started.is_error else task_id_of(started.content)
        if task_id is None:
            raise Finished(
                "failed", f"I couldn't start watching for {thing}: {self.reason(started.content)}."
            )
        info = as_json(started.content)
        skill = str(info.get("skill_id", "watch_for")) if isinstance(info, dict) else "watch_for"
        yield from self.act(Call("mark_step", {"step_id": wait, "status": "running"}))
        while (
            outcome := (yield from self._await(task_id, f"watching for {thing}"))
        ).kind == "paused":
            pass
        yield from self.act(
            Call(
                "mark_step",
                {
                    "step_id": wait,
                    "status": "succeeded" if outcome.kind == "watch_event" else "failed",
                },
            ),
            Call(STOP_SKILL, {"step_id": stop, "skill_id": skill}),
        )
        if outcome.kind == "failed":
            failed = _failed_event(outcome.line)
            raise Finished("failed", f"Watching for {thing} stopped: {self.reason(failed)}.")
        raise Finished("succeeded", f"I saw it: {thing}.")


def _capital(text: str) -> str:
    return text[:1].upper() + text[1:]


def _failed_event(line: str) -> str:
    """A ``[task …] failed CODE (…): message`` line as the error JSON ``reason_of`` reads."""
    match = re.search(r"failed (\S+)[^:]*:\s*(.*?)(?: suggestions: .*)?$", line)
    code, message = (match[1], match[2]) if match is not None else ("", "")
    return json.dumps({"error": code, "detail": message})


def _already_there(leg: Command, at: str | None) -> bool:
    """A search in the place the leg before left the robot ("look for the scissors and a yellow
    package in the mailroom"): no second drive there (issue 32)."""
    return leg.obj is not None and leg.to is None and leg.place == at


_CANNOT_SEE = {
    "network": "the cloud vision service is unreachable",
    "server_error": "the cloud vision service is failing",
    "quota": "the cloud vision quota is used up",
    "timeout": "the vision model did not answer in time",
    "budget": "my cloud vision budget is spent for now",
    "auth": "the cloud vision service refused my key",
}


def _cannot_see(reason: Any) -> str:
    return _CANNOT_SEE.get(str(reason), "the vision model failed")


def _labels(data: Any) -> str:
    if not isinstance(data, dict):
        return ""
    detections = data.get("detections")
    labels = [
        f"{d.get('label')}"
        + (f" ({d['score']:.2f})" if isinstance(d.get("score"), int | float) else "")
        for d in detections or []
        if isinstance(d, dict) and d.get("label")
    ]
    found = (data.get("outputs") or {}).get("found")
    if not labels and isinstance(found, dict) and found.get("value") is True:
        labels = ["it is visible"]
    return ", ".join(labels)


def _mid_sentence(text: str) -> str:
    """A description that starts with an article reads on after "I see": "The mailroom
    shelf." → "the mailroom shelf."; a name ("Alice's desk") keeps its capital."""
    first, _, rest = text.partition(" ")
    return f"{first.lower()} {rest}" if rest and first in ("The", "A", "An", "Some") else text


def _scene_text(data: dict[str, Any]) -> str:
    for key in ("scene_description",):
        value = data.get(key)
        if isinstance(value, dict):
            value = value.get("value")
        if isinstance(value, str) and value.strip():
            return value.strip()
    outputs = data.get("outputs") or {}
    described = outputs.get("scene_description") if isinstance(outputs, dict) else None
    if isinstance(described, dict) and isinstance(described.get("value"), str):
        return str(described["value"])
    labels = [_labels(s) for s in data.get("skills") or [] if isinstance(s, dict)]
    labels.append(_labels(data))
    joined = ", ".join(label for label in labels if label)
    return f"these objects: {joined}." if joined else ""
