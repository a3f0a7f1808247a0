"""A mission as a deterministic program over the live tools, written as a generator: it
yields the tool calls of one planner step (:class:`Act`) and receives what came back
(:class:`Observation`: the results of those calls, the event and user lines since).

    set_plan + list_locations → navigate_to (eta trigger + prewarm reaction) → wait for the
    task → on task_failed read get_task's suggestions and drive the first detour that needs
    no person → find_object → wait_for_result → stop_skill → finish_mission
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from robot_language.commands import Command
from robot_language.listing import Locations
from robot_language.places import PlaceIndex, located
from robot_voice_chat.held_words import holding_answer, names_it
from robot_voice_chat.robot_words import service_name
from robot_voice_chat.services.llm.base import USER_TURN_PREFIX, ToolDefinition
from robot_voice_chat.services.llm.rules.carry import (
    GET_HELD,
    NO_ARM,
    PICK,
    PLACE,
    RELEASE,
    Carrying,
    still_there,
)
from robot_voice_chat.services.llm.rules.driving import NAVIGATE, Driving
from robot_voice_chat.services.llm.rules.looking import (
    INSTANTIATE,
    STOP_SKILL,
    WAIT_RESULT,
    Looking,
)
from robot_voice_chat.services.llm.rules.plain import reason_of
from robot_voice_chat.services.llm.rules.recollection import (
    Names,
    by_id,
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
from robot_voice_chat.services.llm.rules.surface import has_tool

LIST_LOCATIONS = "navigation.list_locations"
# the historical mode of "what do you see" (seed 000 §8): the newest sightings of the last day
UNDERSTOOD = (
    "go to <place>, find <thing> [in <place>], what do you see, watch for <thing>, "
    "fetch <thing> from <place> [and bring it to <place>], pick up <thing>, put it down "
    "[at <place>], hand it over"
)
TASK_EVENT = re.compile(
    r"^\[task (?P<id>\S+) [\w.\-]+\] (?P<kind>done|failed|watch_event)\b(?P<rest>.*)"
)
USER_TURN = USER_TURN_PREFIX  # a mid-mission turn as the executor posts it
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


# Looking and Driving first: their steps stand in for the stubs Carrying declares for them.
class MissionProgram(Looking, Driving, Carrying):
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
            f"I heard {heard!r}, but I'm busy {doing}; say stop to halt me, or abort to end "
            "the mission and then give me the new task."
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
        # issue 39: what the gripper holds before any search (a search for it is answered from
        # the gripper, a fetch of it needs no drive, look or pick); until a leg picks or puts
        in_gripper = (yield from self._held_now()) if carry and self._searches() else None
        for leg in self.legs:
            ids: dict[str, str] = {}
            takes = leg.kind in ("fetch", "pick") and leg.obj is not None
            if leg.kind in ("pick", "put", "release") and not carry:
                raise Finished("failed", f"{NO_ARM}, so I can't pick things up or put them down.")
            searched = leg.obj is not None and leg.kind in ("find", "fetch", "pick")
            if in_gripper is not None and searched and names_it(leg.obj or "", in_gripper):
                ids["in_hand"] = in_gripper  # (a label, not a step)
            if leg.place is not None and not _already_there(leg, at) and "in_hand" not in ids:
                self.needs(NAVIGATE, LIST_LOCATIONS)
                ids["drive"] = self.add_step(f"Drive to the {leg.place}", NAVIGATE)
            if searched and "in_hand" not in ids:
                self.needs(INSTANTIATE, WAIT_RESULT, STOP_SKILL)
                ids["look"] = self.add_look(leg.obj or "", f"Look for the {leg.obj}")
            if takes or leg.kind in ("put", "release"):
                in_gripper = None  # the gripper's contents change from here
            if takes and carry and "in_hand" not in ids:
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
        if self._say_places_in_titles(names, spoken) and self.planned:
            yield from self.act(self.plan_call())  # the plan again, places as people say them
        said: list[str] = []
        place: str | None = None
        for leg, ids in plan:
            if "in_hand" in ids:  # in the gripper: said from the arm's word, not looked for
                self.holding = ids["in_hand"]
                said.append(self._in_hand(leg, ids["in_hand"]))
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
                        f"{NO_ARM}. {still_there(where)}."
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
            bare_drive = not ({"look", "put", "release", "deliver", "in_hand"} & set(ids))
            if bare_drive and place is not None:
                said.append(f"I'm {located(spoken(place))}.")
        raise Finished("succeeded", " ".join(said))

    def _searches(self) -> bool:
        """Some leg looks for a thing (find, fetch, pick): the gripper is read first."""
        return any(leg.obj and leg.kind in ("find", "fetch", "pick") for leg in self.legs)

    @staticmethod
    def _in_hand(leg: Command, label: str) -> str:
        """A leg whose thing the gripper already holds, as the robot says it."""
        if leg.kind == "find":
            return holding_answer(label)
        if leg.to is None:
            return f"I'm already holding the {label}; tell me where to bring it."
        return f"I already have the {label}."

    def _say_places_in_titles(self, names: dict[str, str], spoken: Names) -> bool:
        """Step titles name places as people say them ("Drive to Alice's desk"), never by a
        map id; True if a title changed."""
        changed = False
        for step in self.steps:
            title = step.title
            for phrase, name in names.items():
                title = re.sub(rf"\bthe {re.escape(phrase)}\b", _literal(spoken(name)), title)
            changed |= title != step.title
            step.title = title
        return changed

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


def _literal(text: str) -> str:
    """``text`` as a ``re.sub`` replacement (its backslashes are not group references)."""
    return text.replace("\\", "\\\\")


def _already_there(leg: Command, at: str | None) -> bool:
    """A search in the place the leg before left the robot ("look for the scissors and a yellow
    package in the mailroom"): no second drive there (issue 32)."""
    return leg.obj is not None and leg.to is None and leg.place == at
