"""Carrying things: the manipulation steps of a mission program (pick, read back what is held,
put down or hand over, look to confirm). Mixed into :class:`~.program.MissionProgram`.

Words = world: the robot says it holds something only after the arm's server reported it
(``get_held``), and that something is somewhere only after the camera saw it there. A grasp
that fails is retried once (after a fresh look: the arm needs a recent detection); then the
failure is told as it is, with where the thing still is. Without the manipulation server the
robot never claims to carry anything.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robot_voice_chat.held_words import Held, held_from, names_it
from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolDefinition
from robot_voice_chat.services.llm.rules.steps import Call, Finished, Outcome, PlanStep, Steps
from robot_voice_chat.services.llm.rules.surface import Failure, as_json, has_tool, task_id_of

PICK = "manipulation.pick"
PLACE = "manipulation.place"
RELEASE = "manipulation.release"
GET_HELD = "manipulation.get_held"
MANIP_GET_TASK = "manipulation.get_task"
RETRIED = ("GRASP_FAILED", "NOT_VISIBLE", "DETECTION_STALE", "MANIPULATION_ERROR")
"""Failures a fresh look and one more pick may fix."""
NO_ARM = "I have no arm connected right now"
# what each named failure means, in the robot's words (never the code itself)
_SAID = {
    "GRASP_FAILED": "the grasp didn't hold",
    "NOT_VISIBLE": "the arm couldn't find it where the camera saw it",
    "DETECTION_STALE": "my sighting of it was too old to trust",
    "OUT_OF_REACH": "it is out of my arm's reach from where I stand",
    "ALREADY_HOLDING": "my gripper is already holding something",
    "NOTHING_HELD": "my gripper is empty",
    "NO_SURFACE": "there is no free surface here to put it on",
    "PLACE_FAILED": "it didn't come to rest where I put it",
    "ARM_NOT_READY": "my arm wasn't ready to move",
    "CANCELLED": "it was stopped",
    "ARM_STOPPED": "my arm stopped on its own",
    "MANIPULATION_TIMEOUT": "it took far too long, so I stopped",
    "MANIPULATION_BUSY": "my arm is busy with another task",
    "ARM_UNAVAILABLE": "my arm isn't answering",
}


# the arm's server went away while the call was out (``ToolResult.cut_off``): the arm may
# have started, and nobody can tell yet
CUT_OFF = "CUT_OFF"


def still_there(where: str) -> str:
    """Where a thing it did not pick up is: the place said ("It is still in the mailroom"),
    or where it saw it when no place was named (never "It is still.")."""
    return f"It is still{where}" if where else "It is still where I saw it"


def said(code: str) -> str:
    if code == CUT_OFF:
        return "I lost contact with my arm while it was starting"
    return _SAID.get(code, "my arm reported a problem")


@dataclass(frozen=True)
class Detection:
    label: str
    mask_ref: dict[str, Any]


def detection_of(data: Any, obj: str) -> Detection | None:
    """The best-scoring detection in a perception result whose label names ``obj`` and that
    carries a mask reference (what the arm needs)."""
    if not isinstance(data, dict):
        return None
    words = set(obj.lower().split())
    best: tuple[float, Detection] | None = None
    for det in data.get("detections") or []:
        if not isinstance(det, dict) or not isinstance(det.get("mask_ref"), dict):
            continue
        label = str(det.get("label") or "")
        if not label or not words & set(label.lower().split()):
            continue
        ref = {k: det["mask_ref"][k] for k in ("topic", "stamp", "index") if k in det["mask_ref"]}
        score = float(det["score"]) if isinstance(det.get("score"), int | float) else 0.0
        if best is None or score > best[0]:
            best = (score, Detection(label, ref))
    return best[1] if best else None


class Carrying:
    """The carry steps; :class:`MissionProgram` provides ``act``, ``_look_for``, ``_await``,
    ``_failure``, ``_until_resumed``, the plan's steps and ``seen`` (the last look's result)."""

    tools: list[ToolDefinition]
    steps: list[PlanStep]
    seen: Any

    # -- provided by MissionProgram ---------------------------------------------------------
    def act(self, *calls: Call, text: str = "") -> Steps:
        raise NotImplementedError

    def step_id(self, n: int) -> str:
        raise NotImplementedError

    def plan_call(self) -> Call:
        raise NotImplementedError

    def _look_for(self, obj: str, step_id: str) -> Steps:
        raise NotImplementedError

    def _await(self, task_id: str, reason: str) -> Steps:
        raise NotImplementedError

    def _failure(self, task_id: str, line: str, get_task: str = "") -> Steps:
        raise NotImplementedError

    def _until_resumed(self, reason: str) -> Steps:
        raise NotImplementedError

    # -- planning ----------------------------------------------------------------------------
    def can_carry(self) -> bool:
        return all(has_tool(self.tools, t) for t in (PICK, PLACE, GET_HELD))

    def add_step(self, title: str, tool: str | None) -> str:
        step = self.step_id(len(self.steps) + 1)
        self.steps.append(PlanStep(step, title, tool))
        return step

    def add_look(self, obj: str, title: str) -> str:
        """Three steps (look, read, stop) at the end of the plan; the first one's id."""
        first = self.add_step(title, "skill_control.instantiate_skill")
        self.add_step("Read what the camera found", "perception.wait_for_result")
        self.add_step("Stop the vision skill", "skill_control.stop_skill")
        return first

    def insert_steps(self, after: str, titles: list[tuple[str, str | None]]) -> list[str]:
        """New steps right after ``after`` (a retry), with ids never used before."""
        index = next(i for i, s in enumerate(self.steps) if s.id == after)
        ids = []
        for offset, (title, tool) in enumerate(titles, start=1):
            new_id = f"{after}r{offset}"
            while any(s.id == new_id for s in self.steps):
                new_id += "x"
            self.steps.insert(index + offset, PlanStep(new_id, title, tool))
            ids.append(new_id)
        return ids

    # -- doing -------------------------------------------------------------------------------
    def _motion(self, call: Call, reason: str) -> Steps:
        """Start a pick/place task and wait for it: (outcome, task_id) — or ("error", text)."""
        while True:
            [started] = yield from self.act(call)
            if started.is_error and HELD_BY_SAFETY_STOP in started.content:
                yield from self._until_resumed(f"stopped before {reason}")
                continue
            if started.is_error:
                data = as_json(started.content)
                code = str(data.get("error", "")) if isinstance(data, dict) else ""
                if started.cut_off:
                    code = CUT_OFF
                return Outcome("error", code), ""
            task_id = task_id_of(started.content)
            if task_id is None:
                return Outcome("error", ""), ""
            outcome = yield from self._await(task_id, reason)
            if outcome.kind == "paused":  # a stop cancelled it; the person said continue
                continue
            return outcome, task_id

    def _pick(self, obj: str, where: str, pick_step: str, held_step: str) -> Steps:
        """Pick ``obj`` (just seen: ``self.seen``); retry once after a fresh look. Returns the
        label the arm's server says it holds; ends the mission truthfully otherwise."""
        step, look_again = pick_step, True
        while True:
            found = detection_of(self.seen, obj)
            if found is None:
                raise Finished(
                    "failed",
                    f"I can see the {obj}{where}, but the camera gave my arm no outline of it "
                    "to grasp, so I left it there.",
                )
            args = {"step_id": step, "label": found.label, "mask_ref": found.mask_ref}
            outcome, task_id = yield from self._motion(
                Call(PICK, args), f"picking up the {found.label}"
            )
            if outcome.kind == "done":
                break
            code = outcome.line
            if outcome.kind != "error":
                failure: Failure = yield from self._failure(task_id, outcome.line, MANIP_GET_TASK)
                code = failure.code
            # words = world (issue 39): a pick reported failed — a restarted or killed arm
            # server, a cancel too late — may have closed the gripper on it all the same
            gripper: Held = yield from self._gripper()
            holding = gripper.label
            if holding is not None and names_it(obj, holding):
                break
            if look_again and code in RETRIED:
                look_again = False
                look, pick = self._retry_steps(step, obj)
                yield from self.act(
                    self.plan_call(),
                    Call("say", {"text": f"Hmm, {said(code)}. I'll look again and try once more."}),
                )
                if not (yield from self._look_for(obj, look)):
                    raise Finished(
                        "failed",
                        f"{said(code).capitalize()}, and when I looked again I couldn't see "
                        f"the {obj}{where} any more.",
                    )
                step = pick
                continue
            tried = " (I tried twice)" if not look_again else ""
            # the gripper holds something else (told at the mission's end), or nothing — or,
            # when the arm's server went away mid-call, nobody can say yet (words = world)
            still = (
                "I can't tell yet whether my gripper closed on it"
                if code == CUT_OFF and not gripper.known
                else still_there(where)
            )
            raise Finished("failed", f"I couldn't pick up the {obj}: {said(code)}{tried}. {still}.")
        return (yield from self._held(obj, held_step))

    def _retry_steps(self, after: str, obj: str) -> tuple[str, str]:
        look, _read, _stop, pick = self.insert_steps(
            after,
            [
                (f"Look for the {obj} again", "skill_control.instantiate_skill"),
                ("Read what the camera found", "perception.wait_for_result"),
                ("Stop the vision skill", "skill_control.stop_skill"),
                (f"Pick up the {obj} again", PICK),
            ],
        )
        return look, pick

    def _held(self, obj: str, step: str) -> Steps:
        """What the arm's server says the gripper holds (read back, never assumed)."""
        [answer] = yield from self.act(Call(GET_HELD, {"step_id": step}))
        data = as_json(answer.content) if not answer.is_error else None
        label = data.get("label") if isinstance(data, dict) and data.get("holding") else None
        if not isinstance(label, str) or not label:
            raise Finished(
                "failed",
                f"My arm finished picking up the {obj}, but the gripper reports it holds "
                "nothing, so I don't have it.",
            )
        return label

    def _held_now(self) -> Steps:
        """What the gripper holds now (the arm's server's word), or None."""
        held: Held = yield from self._gripper()
        return held.label

    def _gripper(self) -> Steps:
        """The arm's server's word on the gripper: ``known`` False when it did not answer."""
        [answer] = yield from self.act(Call(GET_HELD))
        return held_from(answer.content, answer.is_error)

    def _put(self, thing: str, mode: str, step: str, where: str) -> Steps:
        """Place (or release) what is held; ends the mission truthfully on a failure."""
        tool = PLACE if mode == "place" else RELEASE
        outcome, task_id = yield from self._motion(
            Call(tool, {"step_id": step}), f"putting the {thing} down"
        )
        if outcome.kind == "done":
            return
        code = outcome.line
        if outcome.kind != "error":
            failure: Failure = yield from self._failure(task_id, outcome.line, MANIP_GET_TASK)
            code = failure.code
        # words = world (issue 39): the gripper's word on what it still holds, not the plan's
        held: Held = yield from self._gripper()
        if not held.known:
            still = "My arm isn't answering, so I can't tell whether I still hold it."
        elif held.label is None:
            still = "My gripper is empty now, but I can't confirm where it went."
        elif names_it(thing, held.label):
            still = "I still hold it."
        else:
            still = f"I'm holding the {held.label}."
        raise Finished("failed", f"I couldn't put the {thing} down{where}: {said(code)}. {still}")

    def _confirm(self, thing: str, look: str) -> Steps:
        """Look where it was put: True when the camera sees it there."""
        seen = yield from self._look_for(thing, look)
        return bool(seen)
