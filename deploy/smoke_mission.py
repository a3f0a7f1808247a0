"""Functional smoke of a running robot stack (spec 002 §12 step 6), driven like the UI does:
REST for the turns, Socket.IO for what the operator sees. Called by deploy/smoke.sh.

    smoke_mission.py URL mission   Teach + "Please fetch the package from the mailroom."
                                   → mission_finished succeeded, teaching_saved <process id>
    smoke_mission.py URL repeat    the same instruction again → the saved process is injected
                                   (checked by smoke.sh in the brain's log: processes_retrieved),
                                   then the "stop" checks below on that mission
    smoke_mission.py URL stop      mid-drive "stop" → navigate task cancelled, mission paused,
                                   the robot asks continue/abort; "abort" ends it

With operator login on, SMOKE_USER / SMOKE_PASSWORD log in first (cookie for REST and the
Socket.IO connect). Prints one line per check; exit 1 with the reason on the first failure.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from typing import Any

from robot_stack_testing.mission_driver import MAILROOM_REQUEST, MissionDriver
from robot_stack_testing.waiting import async_wait_until


class SmokeFailedError(RuntimeError):
    """A smoke check did not hold."""


class OperatorDriver(MissionDriver):
    """MissionDriver that logs in first when the brain asks for an operator."""

    async def __aenter__(self) -> OperatorDriver:
        user, password = os.environ.get("SMOKE_USER", "operator"), os.environ.get("SMOKE_PASSWORD")
        headers: dict[str, str] = {}
        if password:
            response = await self.http.post(
                "/api/auth/login", json={"username": user, "password": password}
            )
            if response.status_code != 200:
                raise SmokeFailedError(f"login as {user} failed: {response.status_code}")
            headers["Cookie"] = "; ".join(f"{k}={v}" for k, v in self.http.cookies.items())
            check(f"logged in as {user}")
        await self.sio.connect(
            self.brain_url, transports=["websocket"], headers=headers, wait_timeout=10
        )
        return self


def check(message: str) -> None:
    sys.stdout.write(f"ok   {message}\n")
    sys.stdout.flush()


def step_status(driver: MissionDriver, tool: str) -> str | None:
    plans = driver.record.of("mission_plan")
    if not plans:
        return None
    for step in plans[-1].get("steps", []):
        if step.get("tool") == tool:
            return str(step.get("status"))
    return None


async def start(driver: MissionDriver, text: str) -> str:
    reply = await driver.send(text)
    mission_id = reply.get("mission_id")
    if reply.get("route") != "mission_started" or not mission_id:
        raise SmokeFailedError(f"no mission started for {text!r}: {reply}")
    check(f"mission {mission_id} started for {text!r}")
    return str(mission_id)


async def mission(driver: MissionDriver, timeout_s: float) -> None:
    armed = await driver.http.post("/api/agent/teaching", json={"enabled": True})
    if armed.json() != {"enabled": True}:
        raise SmokeFailedError(f"teaching not armed: {armed.text}")
    check("teaching armed")
    await start(driver, MAILROOM_REQUEST)
    await async_wait_until(
        lambda: step_status(driver, "navigation.navigate_to") in ("running", "succeeded"),
        timeout_s,
        "the navigate_to step running",
    )
    check("navigate_to step running")
    record = await driver.wait_finished(timeout_s)
    if record.outcome != "succeeded":
        raise SmokeFailedError(f"mission ended {record.outcome}: {record.of('mission_finished')}")
    check(f"mission_finished: succeeded — {record.of('mission_finished')[-1].get('summary')}")
    saved = await async_wait_until(
        lambda: record.of("teaching_saved") or record.of("teaching_failed"),
        timeout_s,
        "teaching_saved",
    )
    if not record.of("teaching_saved"):
        raise SmokeFailedError(f"teaching failed: {saved}")
    check(f"process saved: {record.of('teaching_saved')[-1]['process_id']}")
    sys.stdout.write(f"process_id={record.of('teaching_saved')[-1]['process_id']}\n")


async def repeat(driver: MissionDriver, timeout_s: float) -> None:
    """The taught instruction again (smoke.sh then finds the process in processes_retrieved);
    it is also the mission that gets the mid-drive "stop"."""
    mission_id = await start(driver, MAILROOM_REQUEST)
    sys.stdout.write(f"mission_id={mission_id}\n")
    await stop_mid_drive(driver, timeout_s)


async def stop(driver: MissionDriver, timeout_s: float) -> None:
    await start(driver, MAILROOM_REQUEST)
    await stop_mid_drive(driver, timeout_s)


async def stop_mid_drive(driver: MissionDriver, timeout_s: float) -> None:
    await async_wait_until(
        lambda: step_status(driver, "navigation.navigate_to") == "running",
        timeout_s,
        "the navigate_to step running (mid-drive)",
    )
    check("driving (navigate_to running)")
    await driver.send("stop")

    def paused() -> Any:
        plans = driver.record.of("mission_plan")
        return plans and plans[-1].get("state") == "paused"

    await async_wait_until(paused, timeout_s, "the mission paused after 'stop'")
    check("mission paused after 'stop'")
    if step_status(driver, "navigation.navigate_to") == "running":
        raise SmokeFailedError("the navigate_to step still runs after 'stop'")
    check(f"navigate_to no longer running ({step_status(driver, 'navigation.navigate_to')})")

    def spoken() -> str:
        return " ".join(driver.record.event_lines("say"))  # the UI's activity log

    try:  # the question follows the paused plan; on a busy machine it can come a moment later
        await async_wait_until(lambda: "continue or abort" in spoken().lower(), 10.0, "the ask")
    except TimeoutError:
        raise SmokeFailedError(f"the robot did not ask continue/abort: {spoken()!r}") from None
    check("robot asks: continue or abort?")
    planner = (await driver.http.get("/api/readyz")).json()["data"].get("planner")
    if planner == "replay":
        # A recording plays one scripted mission; it has no branch for the operator's answer.
        check("planner is the recorded replay: the mission stays paused (abort it in the UI)")
        return
    await driver.send("abort")
    await driver.wait_finished(timeout_s)
    check(f"mission ended after 'abort' ({driver.record.outcome})")


STEPS = {"mission": mission, "repeat": repeat, "stop": stop}


async def run(url: str, step: str, timeout_s: float) -> None:
    async with OperatorDriver(url) as driver:
        await driver.wait_servers_connected(timeout_s)
        await STEPS[step](driver, timeout_s)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url", help="the brain, e.g. http://127.0.0.1:8000")
    parser.add_argument("step", choices=sorted(STEPS))
    parser.add_argument("--timeout", type=float, default=120.0)
    args = parser.parse_args(argv)
    try:
        asyncio.run(run(args.url, args.step, args.timeout))
    except (SmokeFailedError, TimeoutError) as exc:
        sys.stdout.write(f"FAIL {args.step}: {exc}\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
