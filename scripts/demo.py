"""`make demo`: the whole stack on the embedded defaults, one mission, narrated as it happens.

Starts every service of ``deploy/local-stack.yaml`` as its own OS process (robot-sim — a
simulated robot with Nav2's NavigateToPose, /amcl_pose and a camera showing the place it is in —,
the vision node on that camera topic with the offline grounder + GrabCut, skill_control,
perception buffer, memory, the episodic memory recording it all, navigation driving robot-sim
through Nav2's action, the brain on its dev preset: the keyless rules chat and the recorded
planner replies), stores a taught process in memory, then acts as the user: one request over
REST, everything else watched over Socket.IO like the UI. The mailroom's west door is closed in
robot-sim's world: the robot sees it on the way and goes round by the east entrance (its own
planner, on its map). At the end the user asks
"what did you see in the last minute?" and the robot answers from its episodic memory. Every
process is stopped by PID at the end, also on Ctrl+C.

    uv run python scripts/demo.py [--keep] [--timeout-s 120]

``--keep`` leaves the stack running after the mission (brain on http://127.0.0.1:8000) until
Ctrl+C. Nothing leaves loopback: servers bind 127.0.0.1, ROS discovery is LOCALHOST-only.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import shutil
import sys
import time
from pathlib import Path

from robot_stack_testing.mission_driver import (
    MAILROOM_REQUEST,
    MissionDriver,
    MissionNotStartedError,
    MissionRecord,
    Narrator,
    RunningStack,
    mailroom_stack,
    seed_memory,
)
from robot_stack_testing.stack import PortsBusyError, StackError

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
VAR_DIR = ROOT / "build" / "demo"
# the chat is the keyless rules chat (it reads the request and answers questions about the past
# from the episodic memory, live); the planner plays its recorded mission
BRAIN_OVERRIDES = {"brain_config_overrides": "llm_planner=replay"}
HISTORY_QUESTION = "what did you see in the last minute?"


def say(text: str) -> None:
    print(text, flush=True)


async def drive(stack: RunningStack, timeout_s: float) -> MissionRecord:
    saved = await seed_memory(stack)
    say(f"demo: memory holds the taught process {saved.get('id')!r} (spec 002 §8)")
    narrator = Narrator(say)
    async with MissionDriver(stack.brain_url, narrator) as user:
        states = await user.wait_servers_connected(30.0)
        say(f"demo: brain connected to {', '.join(sorted(states))}")
        return await user.run_mission(MAILROOM_REQUEST, timeout_s)


async def ask_about_the_past(stack: RunningStack) -> str:
    """One more user turn, answered from the episodic memory (never a motion)."""
    async with MissionDriver(stack.brain_url) as user:
        reply = await user.send(HISTORY_QUESTION)
    return str(reply.get("reply") or "")


def summarize(record: MissionRecord) -> bool:
    steps = record.snapshot.get("steps", [])
    findings = record.findings()
    say("")
    say(f"demo: mission {record.mission_id} {record.outcome}")
    for step in steps:
        say(f"        {step['id']:>4} {step['status']:<9} {step['title']}")
    for finding in findings:
        say(f"demo: the camera saw {finding.label!r}; its mask is at {finding.mask_url}")
    say(f"demo: the mission trace is in {VAR_DIR / 'missions'}; service logs in {VAR_DIR}")
    return record.outcome == "succeeded" and bool(findings)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", action="store_true", help="keep the stack up until Ctrl+C")
    parser.add_argument("--timeout-s", type=float, default=120.0, help="mission deadline")
    args = parser.parse_args(argv)

    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    shutil.rmtree(VAR_DIR, ignore_errors=True)
    say(
        f"demo: starting the stack of {STACK_FILE.relative_to(ROOT)} "
        f"(ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}, discovery LOCALHOST)"
    )
    started = time.monotonic()
    try:
        with mailroom_stack(ROOT, VAR_DIR, BRAIN_OVERRIDES, stack_file=STACK_FILE) as stack:
            for name, process in stack.services.items():
                say(f"demo:   {name:<12} pid {process.pid}")
            say(f"demo: stack up in {time.monotonic() - started:.1f}s\n")
            record = asyncio.run(drive(stack, args.timeout_s))
            ok = summarize(record)
            say(f"\ndemo: you: {HISTORY_QUESTION}")
            answer = asyncio.run(ask_about_the_past(stack))
            say(f"demo: robot: {answer}")
            ok = ok and bool(answer)
            if args.keep:
                say(f"demo: stack left running, brain on {stack.brain_url} — Ctrl+C to stop")
                while True:
                    time.sleep(3600)
    except PortsBusyError as exc:
        say(f"demo: {exc}. Stop the other stack first.")
        return 2
    except (StackError, MissionNotStartedError, TimeoutError) as exc:
        say(f"demo: FAILED — {exc}")
        say(f"demo: service logs are in {VAR_DIR}")
        return 1
    except KeyboardInterrupt:
        say("demo: stopped")
        return 0
    say("demo: OK" if ok else "demo: the mission did not end as expected")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
