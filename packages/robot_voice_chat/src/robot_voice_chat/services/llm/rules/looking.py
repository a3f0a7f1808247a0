"""Looking: the perception steps of a mission program (find an object, describe the scene,
watch for a condition, recall what was seen last). Mixed into :class:`~.program.MissionProgram`.

Words = world: "I can't see right now" is never "it isn't there" (a grounder that could not
answer says so), and a camera that cannot look at all is told as such, naming the part that
does not answer ("My camera system isn't answering, so I can't look right now."; issue 39).
"""

from __future__ import annotations

import json
import re
from typing import Any

from robot_language.places import PlaceIndex
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.llm.rules.plain import down_sentence, part_down, server_part
from robot_voice_chat.services.llm.rules.recollection import last_sightings_sentence, names_of
from robot_voice_chat.services.llm.rules.steps import Call, Finished, PlanStep, Steps
from robot_voice_chat.services.llm.rules.surface import as_json, has_tool, task_id_of

INSTANTIATE = "skill_control.instantiate_skill"
PREWARM = "skill_control.prewarm_skill"
STOP_SKILL = "skill_control.stop_skill"
LIST_SKILLS = "skill_control.list_running_skills"
WAIT_RESULT = "perception.wait_for_result"
WHAT_DO_YOU_SEE = "perception.what_do_you_see"
WHAT_HAPPENED = "episodic.what_happened"
LAST_SIGHTINGS = {"start": "-1d", "kinds": ["sightings"], "max_items": 3}


class Looking:
    """The look steps; :class:`MissionProgram` provides ``act``, ``step_id``, ``plan_call``,
    ``needs``, ``reason``, ``_await``, the plan's steps and the mission's state."""

    tools: list[ToolDefinition]
    steps: list[PlanStep]
    seen: Any
    listed: str | None
    doing: str
    reactions_fired: list[str]
    settings: Any

    # -- provided by MissionProgram ---------------------------------------------------------
    def act(self, *calls: Call, text: str = "") -> Steps:
        raise NotImplementedError

    def step_id(self, n: int) -> str:
        raise NotImplementedError

    def plan_call(self) -> Call:
        raise NotImplementedError

    def needs(self, *names: str) -> None:
        raise NotImplementedError

    def reason(self, content: str) -> str:
        raise NotImplementedError

    def _await(self, task_id: str, reason: str) -> Steps:
        raise NotImplementedError

    # -- the looks ---------------------------------------------------------------------------
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
            part = part_down(started.content)
            if part is not None:
                raise Finished("failed", down_sentence(part, f"look for the {obj}"))
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
        down = (yield from self._vision_down(seen.content)) if seen.is_error else None
        stops = [Call(STOP_SKILL, {"step_id": stop, "skill_id": skill})]
        if any(PREWARM in line for line in self.reactions_fired):
            stops.append(Call(STOP_SKILL, {"skill_id": "prewarm_find_object"}))
        yield from self.act(*stops)
        if down is not None:  # not "I couldn't see it": the camera could not look at all
            raise Finished("failed", down_sentence(down, f"look for the {obj}"))
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

    def _vision_down(self, waited: str) -> Steps:
        """After a wait with no result: is the camera reachable at all? The part that does
        not answer ("My camera system": skill_control cannot reach the vision node; the
        perception buffer itself), else None (it runs: nothing was seen)."""
        part = part_down(waited)
        if part is not None or not has_tool(self.tools, LIST_SKILLS):
            return part
        [listed] = yield from self.act(Call(LIST_SKILLS))
        if not listed.is_error:
            return None
        return part_down(listed.content) or "My camera system"

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
            said = down_sentence(server_part("perception"), "look")
            raise Finished("succeeded", f"{said} {memory}")
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
        down = part_down(view.content) if view.is_error else None
        data = as_json(view.content) if not view.is_error else None
        text = _scene_text(data) if isinstance(data, dict) and data.get("mode") == "warm" else ""
        if text and isinstance(data, dict):  # buffered: is the camera still there to see it?
            gone = yield from self._vision_down("")
            if gone is not None:  # the buffer outlives the vision node by its stale window
                memory = _last_view(text, data.get("age_s"))
                raise Finished("failed", f"{down_sentence(gone, 'look')} {memory}")
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
            if started.is_error:
                down = part_down(started.content) or down
            else:
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
                down = (yield from self._vision_down(fresh.content)) if fresh.is_error else None
        if not text and down is not None:  # never an old sighting as if it were now
            memory = yield from self._remembered()
            raise Finished("failed", f"{down_sentence(down, 'look')} {memory}".rstrip())
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


def _failed_event(line: str) -> str:
    """A ``[task …] failed CODE (…): message`` line as the error JSON ``reason_of`` reads."""
    match = re.search(r"failed (\S+)[^:]*:\s*(.*?)(?: suggestions: .*)?$", line)
    code, message = (match[1], match[2]) if match is not None else ("", "")
    return json.dumps({"error": code, "detail": message})


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


def _last_view(text: str, age_s: Any) -> str:
    """A buffered view said as the past it is: "The last view I have, from 8 s ago, showed
    the charging dock."."""
    age = round(age_s) if isinstance(age_s, int | float) else None
    when = "" if age is None else ", from just now," if age < 1 else f", from {age} s ago,"
    said = _mid_sentence(text)
    return f"The last view I have{when} showed {said}" + ("" if said.endswith(".") else ".")


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
