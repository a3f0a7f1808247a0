"""The simulated office's arm: the manipulation server's tools (pick, place, release, get_held,
stop_manipulation, get_task, cancel_task, list_tasks) with its answers and events, moving the
office's objects. A pick needs a detection the office's camera reported (its mask_ref), the
robot at the place where the thing stands and an empty gripper; ``fail_grasps`` injects failed
grasps, as robot-sim's parameter does; ``drops`` makes a place succeed with nothing arriving."""

from __future__ import annotations

import asyncio
import itertools
import json
from typing import Any

from pydantic import SecretStr

from robot_stack_testing.brain.office_world import OfficeWorld
from robot_voice_chat.services.tools.base import ToolOutcome
from robot_voice_chat.settings import McpServerConfig

ARM_SECRET = "an-arm-event-secret-that-is-32-bytes"  # noqa: S105 - a test fake's


def arm_server() -> McpServerConfig:
    return McpServerConfig(
        name="manipulation",
        url="http://127.0.0.1:9/sse",
        event_secret=SecretStr(ARM_SECRET),
        motion=True,
        safety_stop_tool="stop_manipulation",
        optional=True,
    )


def _error(code: str, detail: str) -> ValueError:
    return ValueError(json.dumps({"error": code, "detail": detail}))


class OfficeArm:
    def __init__(self, world: OfficeWorld, act_s: float = 0.02) -> None:
        self.world = world
        self.act_s = act_s
        self.held: str | None = None
        self.fail_grasps = 0
        self.drops = False  # a place that reports success while the thing fell off the table
        # a pick whose server was killed after the grasp: the gripper holds it, and the
        # restarted server reports the pick lost (SERVER_RESTARTED), as robot-sim's world shows
        self.lost_after_grasp = False
        self.lost_on_place = False  # a place that fails after the gripper opened: it fell
        # the arm's server killed while the pick call was out: the call is cut off, the server
        # gone (get_held does not answer), the gripper as it was
        self.cut_off_pick = False
        self.running: asyncio.Task[None] | None = None
        self._ids = itertools.count(1)
        tools = world.tools
        tools.add("manipulation.pick", self.pick, label="string", mask_ref="object")
        tools.add("manipulation.place", lambda a: self._start("place"))
        tools.add("manipulation.release", lambda a: self._start("release"))
        tools.add("manipulation.get_held", self.get_held)
        tools.add("manipulation.stop_manipulation", self.stop)
        tools.add("manipulation.get_task", world.get_task, task_id="string")
        tools.add("manipulation.cancel_task", self.cancel, task_id="string")
        tools.add("manipulation.list_tasks", world.list_tasks, states="array")
        for name in ("pick", "place", "release"):
            tools.annotate(f"manipulation.{name}", {"readOnlyHint": False, "destructiveHint": True})

    def get_held(self, args: dict[str, Any]) -> dict[str, Any]:
        return {"known": True, "holding": self.held is not None, "label": self.held}

    def pick(self, args: dict[str, Any]) -> dict[str, Any] | ToolOutcome:
        if self.cut_off_pick:
            self.world.tools.states["manipulation"] = "disconnected"
            text = "error: manipulation.pick failed: Connection closed"
            return ToolOutcome(text=text, is_error=True, cut_off=True)
        ref = args.get("mask_ref")
        if not isinstance(ref, dict) or not str(ref.get("topic", "")).startswith("/vision/"):
            raise _error("INVALID_DETECTION", "mask_ref must be a detection's mask_ref")
        return self._start("pick", str(args.get("label", "")))

    def _start(self, tool: str, label: str = "") -> dict[str, Any]:
        if self.running is not None and not self.running.done():
            raise _error("MANIPULATION_BUSY", "the arm is busy")
        task_id = f"manip-{next(self._ids)}"
        info = {"task_id": task_id, "state": "running", "est_duration_s": 8.0, "tool": tool}
        self.world.tasks[task_id] = dict(info, label=label or self.held)
        self.running = asyncio.create_task(self._act(task_id, tool, label))
        return info

    async def _act(self, task_id: str, tool: str, label: str) -> None:
        world = self.world
        await world._post(task_id, "progress", 0, phase="grasping", pct=50)
        await asyncio.sleep(self.act_s)
        here = world.objects.setdefault(world.at, [])
        failure: tuple[str, str, bool] | None = None
        if tool == "pick":
            if self.held is not None:
                failure = ("ALREADY_HOLDING", "the gripper is not empty", True)
            elif label not in here:
                failure = ("NOT_VISIBLE", f"no {label} in reach here", True)
            elif self.fail_grasps > 0:
                self.fail_grasps -= 1
                failure = ("GRASP_FAILED", "the gripper closed on nothing", True)
            else:
                here.remove(label)
                self.held = label
                if self.lost_after_grasp:
                    self.lost_after_grasp = False
                    failure = ("SERVER_RESTARTED", "the server restarted and lost the task", True)
        elif self.held is None:
            failure = ("NOTHING_HELD", "the gripper holds nothing", False)
        elif self.lost_on_place:
            self.lost_on_place, self.held = False, None
            failure = ("PLACE_FAILED", "the gripper opened before it rested", False)
        else:
            if not self.drops:
                here.append(self.held)
            label, self.held = self.held, None
        held = {"holding": self.held is not None, "label": self.held}
        if failure is not None:
            code, message, recoverable = failure
            error = {"error_code": code, "message": message, "recoverable": recoverable,
                     "suggestions": ["look again (find_object), then call pick again"]}  # fmt: skip
            world.tasks[task_id].update(state="failed", error=error)
            await world._post(task_id, "task_failed", 1, **error, held=held)
            return
        result = {"action": tool, "label": label, "held": held}
        world.tasks[task_id].update(state="succeeded", result=result)
        await world._post(task_id, "task_done", 1, **result)

    def _halt(self) -> dict[str, Any] | None:
        if self.running is None or self.running.done():
            return None
        self.running.cancel()
        task = next((t for t in self.world.tasks.values() if t["state"] == "running"
                     and t["task_id"].startswith("manip-")), None)  # fmt: skip
        if task is not None:  # a cancel_task just before may have ended it
            task["state"] = "cancelled"
        return task

    def stop(self, args: dict[str, Any]) -> dict[str, Any]:
        return {"stopped": True, "cancelled_task": self._halt(), "held": self.get_held({})}

    def cancel(self, args: dict[str, Any]) -> dict[str, Any]:
        self._halt()
        return self.world.get_task(args)
