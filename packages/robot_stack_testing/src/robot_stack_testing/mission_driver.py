"""Drive a mission on a running local stack the way a user would, and tell what happened.

Shared by ``make demo`` (``scripts/demo.py``) and ``tests/e2e``: the user types a request
(REST ``POST /api/chat``), the brain answers over Socket.IO (``chat_message``, ``speak``,
``mission_plan``, ``mission_event``, ``mission_finished``) and every event becomes one
narrative line as it arrives. Nothing here fakes a service: the driver only talks to the
brain (REST + Socket.IO) and, to seed and inspect process memory, to the memory MCP server.
"""

from __future__ import annotations

import asyncio
import json
import secrets
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import httpx
import socketio
from mcp import Client

from robot_stack_testing.mcp_auth import approval_meta, mcp_transport
from robot_stack_testing.stack import LocalStack, local_stack, stack_defaults
from robot_stack_testing.waiting import async_wait_until

MAILROOM_REQUEST = "Please fetch the package from the mailroom."
FETCH_REQUEST = "Please fetch the package from the mailroom and bring it to reception."
"""The demo's request (issue 28): the package leaves the mailroom and arrives at reception."""
PACKAGE_LABEL = "yellow package"
MAILROOM_PROCESS_ID = "fetch-package-from-mailroom"
MAILROOM_PROCESS = f"""---
id: {MAILROOM_PROCESS_ID}
title: Fetch a package from the mailroom
task_pattern: fetch the package from the mailroom and tell the user what was found
tags: [mailroom, package, fetch]
---
## Steps
1. navigate_to(mailroom) with trigger eta_below 10; prewarm find_object on the trigger
2. instantiate_skill(find_object, query = the package), then perception.wait_for_result
3. stop_skill when done, tell the user
## Pitfalls & fixes
- The mailroom's west door may be closed: the robot goes round by the east entrance itself;
  if both are closed (NO_PATH), ask someone to open a door.
## Operator notes
- none
"""


def sim_world(*change: str) -> dict[str, Any]:
    """robot-sim's world as its ROS parameters say (``robot-sim-world --show``: ``{"places":
    {place: [labels]}, "held": label | None}``), after an optional change such as
    ``"--fail-grasps", "2"``. Tests read the world here, never from what the robot says."""
    world_cli = [sys.executable, "-m", "robot_sim.world_cli"]
    if change:
        subprocess.run(  # noqa: S603 - our own module, arguments from the test
            [*world_cli, *change], check=True, capture_output=True, timeout=60
        )
    shown = subprocess.run(  # noqa: S603 - our own module
        [*world_cli, "--show"], check=True, capture_output=True, timeout=60
    )
    world: dict[str, Any] = json.loads(shown.stdout)
    return world


SAYS_AT_MOST = 4  # a person repeats what the robot did not catch, and confirms a read-back


def spoken_turn_outcomes(brain_log: str) -> list[str]:
    """How the brain answered each spoken turn, in order ("acted", "read_back",
    "not_acted"), from its ``speech_turn_answered`` log lines."""
    return [
        line.partition('"outcome": "')[2].partition('"')[0]
        for line in brain_log.splitlines()
        if '"event": "speech_turn_answered"' in line
    ]


async def say_on_microphone(text: str, *options: str) -> None:
    """robot-sim-say: a person in the office says ``text`` on the robot's microphone topic
    (``options``: espeak-ng's, e.g. ``--speed 180``)."""
    process = await asyncio.create_subprocess_exec(
        shutil.which("robot-sim-say") or "robot-sim-say",
        text,
        *options,
        "--wait-s",
        "20",
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT,
    )
    async with asyncio.timeout(60):
        output, _ = await process.communicate()
    assert process.returncode == 0, output.decode(errors="replace")


def reissued_after_a_stall(sim_log: str) -> bool:
    """robot-sim stood still long enough for navigation to call the base lost (its stall
    watch logs ``robot_sim_stalled``), and the brain re-issued the drive (issue 39): a goal
    cancelled, another accepted. The re-issued goal plans from what the robot already knew
    (a door it saw closed), so a detour shows in its plan, not in a replan."""
    accepted = sim_log.count('"event": "goal_accepted"')
    return '"robot_sim_stalled"' in sim_log and '"goal_canceled"' in sim_log and accepted >= 2


def fresh_secret() -> str:
    return secrets.token_urlsafe(32)


def stack_env(secret: str) -> dict[str, str]:
    """The runner's environment: one fresh HMAC secret for the servers (RVC_EVENT_SECRET)
    and the brain (per-server NAV_/PERCEPTION_/MANIP_EVENT_SECRET); ROS discovery on loopback."""
    return {
        "RVC_EVENT_SECRET": secret,
        "NAV_EVENT_SECRET": secret,
        "PERCEPTION_EVENT_SECRET": secret,
        "MANIP_EVENT_SECRET": secret,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
    }


async def call_mcp(
    url: str,
    tool: str,
    arguments: Mapping[str, Any],
    timeout_s: float = 20.0,
    *,
    token: str | None = None,
    meta: dict[str, Any] | None = None,
) -> Any:
    """One MCP tool call (``…/sse``: SSE, else streamable-http) presenting ``token``, the
    server's credential, with ``meta`` as its ``_meta``; the decoded JSON answer
    (``{"_error": ...}`` if it failed)."""
    async with asyncio.timeout(timeout_s), Client(mcp_transport(url, token)) as client:
        result = await client.call_tool(tool, dict(arguments), meta=meta)  # type: ignore[arg-type]
    text = "".join(getattr(block, "text", "") for block in result.content)
    try:
        payload = json.loads(text)
    except ValueError:
        payload = text
    return {"_error": payload} if result.is_error else payload


class MissionNotStartedError(RuntimeError):
    """The user's turn was answered without starting a mission."""


@dataclass
class RunningStack:
    """A started local stack and where to reach it."""

    services: LocalStack
    placeholders: dict[str, str]
    secret: str
    var_dir: Path | None = None

    @property
    def sim_scenes_dir(self) -> Path:
        """Where robot-sim saves every frame it publishes (with its annotations)."""
        template = self.placeholders["sim_scenes_dir"]
        return Path(template.format(var=self.var_dir, root=self.services.root))

    def url(self, service: str, path: str = "") -> str:
        return f"http://127.0.0.1:{self.placeholders[f'{service}_port']}{path}"

    @property
    def credentials(self) -> dict[str, str]:
        """This run's MCP credential of each server (``deploy/local-stack.yaml``)."""
        return self.services.credentials

    def write_operator_credentials(self, path: Path) -> Path:
        """The operators' credentials as install.sh writes ``operator.env`` (for smoke.sh)."""
        lines = [
            f"{name.upper()}_MCP_OPERATOR_TOKEN={token}\n"
            for name, token in self.services.operator_credentials.items()
        ]
        path.write_text("".join(lines))
        path.chmod(0o600)
        return path

    async def call(
        self,
        service: str,
        tool: str,
        arguments: Mapping[str, Any],
        meta: dict[str, Any] | None = None,
    ) -> Any:
        """One tool call to an MCP server of the stack over SSE, with its credential."""
        return await call_mcp(
            self.url(service, "/sse"), tool, arguments, token=self.credentials[service], meta=meta
        )

    def approval(self, service: str, tool: str, arguments: Mapping[str, Any]) -> dict[str, Any]:
        """The ``_meta`` of an operator's approval of exactly this call, signed with this
        run's approval secret of ``service`` (``approval_<service>`` in the stack file)."""
        return approval_meta(
            self.services.secrets[f"approval_{service}"],
            server=service,
            tool=tool,
            arguments=arguments,
            approval_id=f"test-{secrets.token_hex(6)}",
            by="test operator",
        )

    @property
    def brain_url(self) -> str:
        return self.url("brain")


@contextmanager
def mailroom_stack(
    root: Path,
    var_dir: Path,
    overrides: Mapping[str, str] | None = None,
    stack_file: Path | None = None,
) -> Iterator[RunningStack]:
    """The whole stack (``deploy/local-stack.yaml``) with a fresh secret, stopped by PID when
    the block exits. The camera is robot-sim's: it shows the place the robot stands at."""
    path = stack_file or root / "deploy" / "local-stack.yaml"
    placeholders = {**stack_defaults(path), **(overrides or {})}
    secret = fresh_secret()
    with local_stack(
        root, var_dir, stack_env(secret), stack_file=path, overrides=placeholders
    ) as services:
        yield RunningStack(services, placeholders, secret, var_dir)


async def seed_memory(stack: RunningStack, markdown: str = MAILROOM_PROCESS) -> Any:
    """Store a process document, as a past teaching would have (spec 002 §8): with an
    operator's approval, as the brain sends it (the server stores nothing without one)."""
    arguments = {"markdown": markdown}
    approval = stack.approval("memory", "save_process", arguments)
    return await stack.call("memory", "save_process", arguments, approval)


@dataclass
class Finding:
    label: str
    score: float
    mask_url: str


@dataclass
class MissionRecord:
    """Everything the user saw, in arrival order, plus the brain's final snapshot."""

    events: list[tuple[str, Any]] = field(default_factory=list)
    reply: dict[str, Any] = field(default_factory=dict)
    snapshot: dict[str, Any] = field(default_factory=dict)
    replies: list[str] = field(default_factory=list)  # every REST reply, in order

    def robot_words(self) -> list[str]:
        """Everything shown or said as the robot's words: REST and chat replies, spoken and
        said lines, mission summaries (not plan steps, tool calls or task events)."""
        said = list(self.replies)
        for name, data in self.events:
            if not isinstance(data, dict):
                continue
            if (name == "chat_message" and data.get("role") == "assistant") or (
                name == "mission_event" and data.get("kind") == "say"
            ):
                said.append(str(data.get("text", "")))
            elif name in ("speak", "chat_error"):
                said.append(str(data.get("text") or data.get("message") or ""))
            elif name == "mission_finished":
                said.append(str(data.get("summary", "")))
        return [s for s in said if s]

    def of(self, name: str) -> list[Any]:
        return [data for event, data in self.events if event == name]

    @property
    def mission_id(self) -> str | None:
        started = self.of("mission_started")
        return str(started[0]["mission_id"]) if started else self.reply.get("mission_id")

    @property
    def outcome(self) -> str | None:
        finished = self.of("mission_finished")
        return str(finished[-1]["outcome"]) if finished else None

    def event_lines(self, kind: str | None = None) -> list[str]:
        return [
            str(e["text"]) for e in self.of("mission_event") if kind is None or e["kind"] == kind
        ]

    def tool_results(self, tool: str) -> list[dict[str, Any]]:
        """The snapshot's ``tool_result`` records of one dotted tool (MCP answers as text)."""
        return [
            e
            for e in self.snapshot.get("events", [])
            if e.get("kind") == "tool_result" and e.get("tool") == tool
        ]

    def findings(self) -> list[Finding]:
        """What perception answered (``wait_for_result`` / ``get_latest``): labels + mask refs."""
        found = []
        for record in self.tool_results("perception.wait_for_result") + self.tool_results(
            "perception.get_latest"
        ):
            if record.get("is_error"):
                continue
            try:
                result = json.loads(record["result"])
            except (ValueError, KeyError):
                continue
            for detection in result.get("detections", []):
                ref = detection.get("mask_ref") or {}
                found.append(
                    Finding(str(detection["label"]), float(detection["score"]), str(ref.get("url")))
                )
        return found


class Narrator:
    """Turns brain events into one readable line each (only what changed). A step whose
    status stays the same (a drive's ETA ticking down) is reported at most every
    ``progress_every_s``; a status change is always reported."""

    def __init__(self, write: Callable[[str], None], progress_every_s: float = 1.0) -> None:
        self.write = write
        self.progress_every_s = progress_every_s
        self.started = time.monotonic()
        self._steps: dict[str, tuple[str, str]] = {}
        self._reported_at: dict[str, float] = {}
        self._step_ids: list[str] = []

    def line(self, text: str) -> None:
        self.write(f"[{time.monotonic() - self.started:5.1f}s] {text}")

    def event(self, name: str, data: Any) -> None:
        handler = getattr(self, f"_on_{name}", None)
        if handler is not None and isinstance(data, dict):
            handler(data)

    def _on_chat_message(self, data: dict[str, Any]) -> None:
        who = "user said " if data.get("role") == "user" else "robot said"
        self.line(f"{who}: {data.get('text')!r}")

    def _on_speak(self, data: dict[str, Any]) -> None:
        self.line(f"robot says : {data.get('text')!r}")

    def _on_mission_started(self, data: dict[str, Any]) -> None:
        self.line(f"mission {data.get('mission_id')} started: {data.get('instruction')}")

    def _on_mission_plan(self, data: dict[str, Any]) -> None:
        steps = data.get("steps", [])
        step_ids = [str(s["id"]) for s in steps]
        if step_ids != self._step_ids:
            self._step_ids = step_ids
            label = "plan" if not self._steps else "plan updated (replanned)"
            self.line(f"{label}:")
            for s in steps:
                tool = f"  [{s['tool']}]" if s.get("tool") else ""
                self.write(f"          {s['id']:>4} {s['title']}{tool}")
        for s in steps:
            state = (str(s.get("status")), str(s.get("detail", "")))
            if self._worth_reporting(s["id"], state):
                detail = f" — {state[1][:100]}" if state[1] else ""
                self.line(f"step {s['id']} {state[0]}{detail}")
                self._reported_at[s["id"]] = time.monotonic()
            self._steps[s["id"]] = state

    def _worth_reporting(self, step_id: str, state: tuple[str, str]) -> bool:
        previous = self._steps.get(step_id)
        if state == previous or state[0] == "pending":
            return False
        if previous is None or previous[0] != state[0]:
            return True
        return time.monotonic() - self._reported_at.get(step_id, 0.0) >= self.progress_every_s

    def _on_mission_event(self, data: dict[str, Any]) -> None:
        if data.get("kind") in ("say", "user_turn"):
            return  # shown as speak / chat_message
        self.line(f"{data.get('kind')}: {data.get('text')}")

    def _on_mission_finished(self, data: dict[str, Any]) -> None:
        self.line(f"mission {data.get('outcome')}: {data.get('summary')}")

    def findings(self, findings: list[Finding]) -> None:
        for f in findings:
            self.line(f"vision found {f.label!r} (score {f.score:.2f}), mask_ref {f.mask_url}")


class MissionDriver:
    """A user at the brain: REST for the turn, Socket.IO for everything the UI shows.

    ``words_check`` (a checker such as ``robot_voice_chat.robot_words.leaks``; the e2e
    conftest sets it) reads every sentence the robot said or showed when the driver closes,
    and raises if any leaks a task id, tool name, code or snake_case id."""

    words_check: ClassVar[Callable[[str], list[Any]] | None] = None

    def __init__(self, brain_url: str, narrator: Narrator | None = None) -> None:
        self.brain_url = brain_url.rstrip("/")
        self.narrator = narrator
        self.record = MissionRecord()
        self.http = httpx.AsyncClient(base_url=self.brain_url, timeout=30.0)
        self.sio = socketio.AsyncClient(reconnection=False)
        self.sio.on("*", self._on_event)
        self._reported: set[str] = set()

    async def __aenter__(self) -> MissionDriver:
        await self.sio.connect(self.brain_url, transports=["websocket"], wait_timeout=10)
        return self

    async def __aexit__(self, exc_type: object, *exc: object) -> None:
        await self.sio.disconnect()
        await self.http.aclose()
        check = type(self).words_check
        if check is not None and exc_type is None:
            found = [leak for said in self.record.robot_words() for leak in check(said)]
            if found:
                raise AssertionError(f"the robot's words leak: {found[:5]}")

    async def _on_event(self, name: str, data: Any = None) -> None:
        self.record.events.append((name, data))
        if self.narrator is None:
            return
        self.narrator.event(name, data)
        if name == "mission_plan" and isinstance(data, dict) and self._perception_done(data):
            await self._narrate_findings(str(data["mission_id"]))

    def _perception_done(self, plan: dict[str, Any]) -> bool:
        done = {
            s["id"]
            for s in plan.get("steps", [])
            if str(s.get("tool", "")).startswith("perception.") and s.get("status") == "succeeded"
        }
        new = done - self._reported
        self._reported |= new
        return bool(new)

    async def _narrate_findings(self, mission_id: str) -> None:
        response = await self._snapshot(mission_id)
        if response.status_code == 200 and self.narrator is not None:
            self.narrator.findings(MissionRecord(snapshot=response.json()).findings())

    async def _snapshot(self, mission_id: str | None) -> httpx.Response:
        return await self.http.get(f"/api/agent/missions/{mission_id}")

    async def wait_servers_connected(self, timeout_s: float = 30.0) -> dict[str, str]:
        """Wait until the brain reports every MCP server connected (``/api/readyz``)."""

        async def connected() -> dict[str, str]:
            states: dict[str, str] = (await self.http.get("/api/readyz")).json()["data"][
                "mcp_servers"
            ]
            return states if all(s == "connected" for s in states.values()) else {}

        return await async_wait_until(connected, timeout_s, "every MCP server connected", 0.2)

    async def send(self, text: str) -> dict[str, Any]:
        """A user turn over REST (the Socket.IO ``send_message`` twin)."""
        response = await self.http.post("/api/chat", json={"text": text})
        response.raise_for_status()
        reply: dict[str, Any] = response.json()
        self.record.reply = reply
        self.record.replies.append(str(reply.get("reply", "")))
        return reply

    async def wait_finished(self, timeout_s: float) -> MissionRecord:
        """Wait for ``mission_finished`` (deadline-bound), then fetch the mission snapshot."""
        await async_wait_until(
            lambda: self.record.of("mission_finished"), timeout_s, "mission_finished", 0.05
        )
        response = await self._snapshot(self.record.mission_id)
        response.raise_for_status()
        self.record.snapshot = response.json()
        return self.record

    async def run_mission(self, request: str, timeout_s: float) -> MissionRecord:
        """One user turn that should start a mission; then wait for it to finish."""
        reply = await self.send(request)
        if not reply.get("mission_id"):
            raise MissionNotStartedError(f"the robot did not start a mission: {reply}")
        return await self.wait_finished(timeout_s)
