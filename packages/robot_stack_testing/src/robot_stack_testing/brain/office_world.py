"""A simulated office behind the fake tool backend (tests, benchmarks): a robot base that
drives between named places and pushes task events, a mailroom door that is closed the first
time, and camera skills that see what stands at the robot's place. Tools and answers have
the shapes of the real navigation, skill_control and perception servers."""

from __future__ import annotations

import asyncio
import itertools
import json
import time
from collections.abc import Awaitable, Callable
from typing import Any

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.services.tools.fake import FakeToolBackend

Deliver = Callable[[TaskEvent], Awaitable[Any]]
PLACES: dict[str, list[str]] = {
    "dock": [],
    "reception": ["front_desk"],
    "kitchen": [],
    "corridor_b": [],
    "mailroom": ["mail_room", "post_room"],
}
SEEN_AT = {"mailroom": ["yellow package"], "kitchen": ["scissors", "red mug"]}
"""What stands where when the office starts (each OfficeWorld keeps its own copy)."""
DOOR_SUGGESTIONS = [
    'ask someone to open the mailroom door, then call navigate_to("mailroom") again',
    "use the east entrance via corridor_b "
    '(navigate_to("corridor_b"), then navigate_to("mailroom"))',
    'ask reception (navigate_to("reception")) for help',
]


class OfficeWorld:
    def __init__(self, tools: FakeToolBackend, drive_s: float = 0.05, door_closed: bool = True):
        self.tools = tools
        self.drive_s = drive_s
        self.door_closed = door_closed
        self.at = "dock"
        # list_locations with distances (off by off_m from ``at``: a drive halted on its way)
        self.distances = False
        self.off_m = 0.0
        self.unreachable: set[str] = set()  # places no drive reaches (no way through)
        self.drive_times: dict[str, float] = {}  # drives that take longer than drive_s
        self.deliver: Deliver | None = None
        self.tasks: dict[str, dict[str, Any]] = {}
        self.driving: asyncio.Task[None] | None = None
        self.arm: Any = None  # an OfficeArm when the robot has one
        self._ids = itertools.count(1)
        self._background: set[asyncio.Task[None]] = set()
        self.last_query = ""
        self.objects = {place: list(SEEN_AT.get(place, [])) for place in PLACES}
        self.stamps = itertools.count(1_700_000_000)
        nav = {
            "navigate_to": (self.navigate_to, {"location": "string", "triggers": "array"}),
            "list_locations": (self.list_locations, {}),
            "get_task": (self.get_task, {"task_id": "string"}),
            "cancel_task": (self.cancel_task, {"task_id": "string"}),
            "stop_navigation": (self.stop_navigation, {}),
            "list_tasks": (self.list_tasks, {"states": "array"}),
        }
        for name, (handler, props) in nav.items():
            tools.add(f"navigation.{name}", handler, **props)
        tools.add(
            "skill_control.instantiate_skill", self.instantiate, template="string", params="object"
        )
        tools.add("skill_control.prewarm_skill", self.prewarm, template="string", params="object")
        tools.add(
            "skill_control.stop_skill",
            lambda a: {"skill_id": a["skill_id"], "stopped": True},
            skill_id="string",
        )
        tools.add(
            "perception.wait_for_result", self.wait_for_result, skill="string", timeout_s="number"
        )
        tools.add("perception.what_do_you_see", self.what_do_you_see)

    # --- navigation ------------------------------------------------------------------------
    def resolve(self, location: str) -> str | None:
        key = location.strip().lower().replace(" ", "_")
        return next((p for p, aliases in PLACES.items() if key == p or key in aliases), None)

    def list_locations(self, args: dict[str, Any]) -> dict[str, Any]:
        locations: list[dict[str, Any]] = [
            {"name": p, "aliases": a, "description": p} for p, a in PLACES.items()
        ]
        if self.distances:  # as the real server: each place's distance from the robot
            for item in locations:
                here = item["name"] == self.at
                item["distance_m"] = self.off_m + (0.0 if here else 8.0)
        return {"map": "office", "locations": locations}

    def navigate_to(self, args: dict[str, Any]) -> dict[str, Any]:
        place = self.resolve(str(args.get("location", "")))
        if place is None:
            detail = f"unknown location {args.get('location')!r}"
            raise ValueError(json.dumps({"error": "UNKNOWN_LOCATION", "detail": detail}))
        if self.driving is not None and not self.driving.done():
            raise ValueError('{"error": "NAVIGATION_BUSY", "detail": "a navigation is running"}')
        task_id = f"nav-{next(self._ids)}"
        info = {
            "task_id": task_id,
            "state": "running",
            "est_duration_s": 20.0,
            "destination": place,
        }
        self.tasks[task_id] = dict(info)
        self.driving = asyncio.create_task(
            self._drive(task_id, place, list(args.get("triggers") or []))
        )
        return info

    async def _drive(self, task_id: str, place: str, triggers: list[Any]) -> None:
        seq = itertools.count()
        drive_s = self.drive_times.get(place, self.drive_s)
        await self._post(task_id, "progress", next(seq), eta_s=15, pct=25)
        await asyncio.sleep(drive_s / 2)
        for trigger in triggers:
            if isinstance(trigger, dict) and trigger.get("type") == "eta_below":
                await self._post(
                    task_id, "trigger_fired", next(seq), eta_s=9.0, trigger=dict(trigger)
                )
        await asyncio.sleep(drive_s / 2)
        if place in self.unreachable:
            failure = {"error_code": "NO_PATH", "message": "no valid path: the way is blocked",
                       "recoverable": False, "suggestions": []}  # fmt: skip
            self.tasks[task_id].update(state="failed", error=failure)
            await self._post(task_id, "task_failed", next(seq), **failure)
            return
        if place == "mailroom" and self.door_closed and self.at != "corridor_b":
            self.door_closed = False  # once: the next drive there gets in
            failure = {
                "error_code": "DOOR_CLOSED",
                "message": "The mailroom door is closed.",
                "recoverable": True,
                "suggestions": DOOR_SUGGESTIONS,
            }
            self.tasks[task_id].update(state="failed", error=failure)
            await self._post(task_id, "task_failed", next(seq), **failure)
            return
        self.at, self.off_m = place, 0.0
        self.tasks[task_id].update(state="succeeded", result={"arrived": place})
        await self._post(task_id, "task_done", next(seq), result={"arrived": place})

    async def _post(self, task_id: str, type_: str, seq: int, **payload: Any) -> None:
        if self.deliver is None:
            return
        server, tool = (
            ("perception", "instantiate_skill")
            if task_id.startswith("watch-")
            else ("manipulation", str(self.tasks[task_id]["tool"]))
            if task_id.startswith("manip-")
            else ("navigation", "navigate_to")
        )
        event = TaskEvent(
            task_id=task_id,
            server=server,
            tool=tool,
            type=type_,
            seq=seq,
            ts=time.time(),
            payload=payload,
        )
        await self.deliver(event)

    def get_task(self, args: dict[str, Any]) -> dict[str, Any]:
        task = self.tasks.get(str(args.get("task_id")))
        if task is None:
            raise ValueError('{"error": "UNKNOWN_TASK", "detail": "no such task"}')
        return task

    def _halt(self) -> None:
        if self.driving is not None and not self.driving.done():
            self.driving.cancel()
            self.off_m = 3.0  # it stopped on its way, 3 m from where it set off
            for task in self.tasks.values():
                if task["state"] == "running" and task["task_id"].startswith("nav-"):
                    task["state"] = "cancelled"

    def cancel_task(self, args: dict[str, Any]) -> dict[str, Any]:
        self._halt()
        return self.get_task(args)

    def stop_navigation(self, args: dict[str, Any]) -> dict[str, Any]:
        self._halt()
        return {"stopped": True, "pose": {"at": self.at}}

    def list_tasks(self, args: dict[str, Any]) -> dict[str, Any]:
        states = args.get("states")
        return {"tasks": [t for t in self.tasks.values() if not states or t["state"] in states]}

    # --- camera ----------------------------------------------------------------------------
    def instantiate(self, args: dict[str, Any]) -> dict[str, Any]:
        template = str(args.get("template"))
        skill = {
            "skill_id": template,
            "topic": f"/vision/{template}/detections",
            "mode": "describe",
        }
        if template == "watch_for":
            task_id = f"watch-{template}"
            skill.update(task_id=task_id, state="running", server="perception")
            self.tasks[task_id] = {"task_id": task_id, "state": "running"}
            task = asyncio.create_task(
                self._watch(task_id, str((args.get("params") or {}).get("condition")))
            )
            self._background.add(task)
            task.add_done_callback(self._background.discard)
        elif template not in ("find_object", "describe_scene"):
            raise ValueError(
                f'{{"error": "unknown_template", "detail": "no template {template!r}"}}'
            )
        self.last_query = str((args.get("params") or {}).get("query", ""))
        return skill

    async def _watch(self, task_id: str, condition: str) -> None:
        await asyncio.sleep(self.drive_s)
        await self._post(
            task_id, "watch_event", 0, output="triggered", value=True, condition=condition
        )

    def prewarm(self, args: dict[str, Any]) -> dict[str, Any]:
        return {"skill_id": f"prewarm_{args.get('template')}", "prewarm": True}

    def wait_for_result(self, args: dict[str, Any]) -> dict[str, Any]:
        skill = str(args.get("skill"))
        seen = self.objects.get(self.at, [])
        if skill == "describe_scene":
            text = f"an office room with {', '.join(seen) or 'nothing special'}"
            return {
                "skill": skill,
                "detections": [],
                "outputs": {"scene_description": {"value": text}},
            }
        head = self.last_query.split()[-1] if self.last_query else ""
        hits = [label for label in seen if head and label.split()[-1] == head]
        stamp = float(next(self.stamps))
        topic = f"/vision/{skill}/detections"
        detections = [
            {
                "label": label,
                "score": 0.91,
                "box": [10, 10, 50, 50],
                "mask_ref": {"topic": topic, "stamp": stamp, "index": i, "url": None},
            }
            for i, label in enumerate(hits)
        ]
        return {
            "skill": skill,
            "detections": detections,
            "outputs": {"found": {"value": bool(hits)}},
        }

    def what_do_you_see(self, args: dict[str, Any]) -> dict[str, Any]:
        return {
            "mode": "cold",
            "scene_description": None,
            "skills": [],
            "hint": "instantiate describe_scene",
        }
