import asyncio
import contextlib
import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.caller import PRINCIPAL_SCOPE_KEY, CallerContext
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, parse_tool_error
from robot_mcp_kit.supervision import (
    FOREIGN_HOLDER,
    LOCK_TOPIC_SHARED,
    NOT_PERMITTED,
    NOT_SUPERVISED,
    POSE_TOPIC_SHARED,
    SAFETY_STOP_LATCHED,
    SUPERVISION_ALARM,
    LeaseError,
    Supervision,
)
from robot_mcp_kit.supervision_tools import add_supervise_tool, watch_supervision


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def supervised(clock: Clock, **kwargs: object) -> Supervision:
    return Supervision(clock=clock, **kwargs)  # type: ignore[arg-type]


def test_a_server_that_just_started_refuses_motion_and_locks_until_a_lease_arrives() -> None:
    clock = Clock()
    supervision = supervised(clock)

    refused = supervision.refusal()

    assert refused is not None
    assert refused.code == NOT_SUPERVISED
    assert "since this server started" in refused.detail
    assert supervision.locked()


def test_a_fresh_lease_with_the_stop_clear_allows_motion_and_opens_the_lock() -> None:
    clock = Clock()
    supervision = supervised(clock)

    supervision.renew("brain-1", 0.8, latched=False)

    assert supervision.refusal() is None
    assert not supervision.locked()
    assert supervision.status()["lock"] == "open"


def test_the_lease_lapses_after_its_ttl_and_motion_is_refused_again() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)

    clock.now += 0.79
    assert not supervision.locked()
    clock.now += 0.02

    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == NOT_SUPERVISED
    assert "lapsed" in refused.detail
    assert supervision.locked()


def test_a_latched_lease_refuses_motion_and_locks_even_while_fresh() -> None:
    clock = Clock()
    supervision = supervised(clock)

    supervision.renew("brain-1", 0.8, latched=True, reason="person in the way")

    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == SAFETY_STOP_LATCHED
    assert "person in the way" in refused.detail
    assert supervision.locked()


def test_the_latch_outlives_its_lease_until_a_fresh_lease_clears_it() -> None:
    clock = Clock()
    supervision = supervised(clock, required=False)
    supervision.renew("brain-1", 0.8, latched=True)
    clock.now += 5

    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == SAFETY_STOP_LATCHED

    supervision.renew("brain-2", 0.8, latched=False)
    assert supervision.refusal() is None


def test_without_required_supervision_motion_needs_no_lease_but_the_lock_stays_locked() -> None:
    clock = Clock()
    supervision = supervised(clock, required=False)

    assert supervision.refusal() is None
    assert supervision.locked()


@pytest.mark.parametrize(
    ("holder", "ttl_s"), [("", 0.5), ("b", 0.0), ("b", -1.0), ("b", 2.5), ("b", float("nan"))]
)
def test_a_bad_renewal_is_refused_and_changes_nothing(holder: str, ttl_s: float) -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)

    with pytest.raises(LeaseError):
        supervision.renew(holder, ttl_s, latched=False)

    assert supervision.lease is not None
    assert supervision.lease.holder == "brain-1"


def test_poll_reports_a_lapse_once_when_motion_was_allowed() -> None:
    clock = Clock()
    supervision = supervised(clock)
    assert supervision.poll() is None  # never allowed: nothing to end
    supervision.renew("brain-1", 0.8, latched=False)
    assert supervision.poll() is None

    clock.now += 1.0

    assert supervision.poll() == "lapsed"
    assert supervision.poll() is None


def test_poll_reports_a_latch_even_when_it_was_cleared_before_the_poll() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    supervision.poll()

    supervision.renew("brain-1", 0.8, latched=True)
    supervision.renew("brain-1", 0.8, latched=False)

    assert supervision.poll() == "latched"
    assert supervision.poll() is None


def test_release_ends_only_the_holders_own_lease() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)

    assert not supervision.release("brain-2")
    assert supervision.release("brain-1")
    assert supervision.locked()


async def test_the_supervise_tool_renews_the_lease_and_refuses_a_bad_ttl() -> None:
    supervision = Supervision(max_ttl_s=2.0)
    server = MCPServer("motion")
    install_json_tool_errors(server)
    add_supervise_tool(server, supervision)

    async with Client(server) as client:
        ok = await client.call_tool("supervise", {"holder": "brain-1", "latched": False})
        bad = await client.call_tool(
            "supervise", {"holder": "brain-1", "latched": False, "ttl_s": 9}
        )

    answer = json.loads(ok.content[0].text)  # type: ignore[union-attr]
    assert answer["supervised"] is True
    assert answer["lock"] == "open"
    assert bad.is_error
    assert json.loads(bad.content[0].text)["error"] == "INVALID_LEASE"  # type: ignore[union-attr]


async def test_the_watchdog_ends_motion_with_the_reason_when_the_lease_latches() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    ended: list[str] = []
    done = asyncio.Event()

    async def end_motion(reason: str) -> None:
        ended.append(reason)
        done.set()

    supervision.renew("brain-1", 0.8, latched=True)
    watchdog = asyncio.create_task(
        watch_supervision(supervision, end_motion, lambda: not ended, period_s=0.01)
    )
    try:
        async with asyncio.timeout(5):
            await done.wait()
    finally:
        watchdog.cancel()

    assert ended == ["the software stop was latched"]


async def test_the_watchdog_publishes_the_lock_at_once_whenever_its_value_changes() -> None:
    clock = Clock()
    supervision = supervised(clock)
    published: list[bool] = []
    changed = asyncio.Event()

    def publish() -> None:
        published.append(supervision.locked())
        changed.set()

    async def never(reason: str) -> None:
        raise AssertionError("nothing moves here")

    watchdog = asyncio.create_task(
        watch_supervision(supervision, never, lambda: False, 0.01, publish_lock=publish)
    )
    try:
        async with asyncio.timeout(5):
            await changed.wait()  # the first look: locked (no lease yet)
            changed.clear()
            supervision.renew("brain-1", 0.8, latched=False)
            await changed.wait()
            changed.clear()
            clock.now += 1.0  # lapsed
            await changed.wait()
    finally:
        watchdog.cancel()

    assert published == [True, False, True]


class StarvedSleep:
    """The watchdog's sleep on the fake clock. ``starved[n]``: how much longer the n-th sleep
    takes (the process was not scheduled); ``then[n]``: what happens during it (the inbox)."""

    def __init__(self, clock: Clock, ticks: int) -> None:
        self.clock = clock
        self.calls = 0
        self.ticks = ticks
        self.done = asyncio.Event()  # the watchdog has slept ``ticks`` times
        self.starved: dict[int, float] = {}
        self.then: dict[int, Callable[[], object]] = {}

    async def __call__(self, seconds: float) -> None:
        self.calls += 1
        self.clock.now += seconds + self.starved.get(self.calls, 0.0)
        if self.calls in self.then:
            self.then[self.calls]()
        if self.calls >= self.ticks:
            self.done.set()
        await asyncio.sleep(0)


@dataclass(frozen=True)
class Ended:
    """One call of the watchdog's ``end_motion``: why, when (the fake clock), after how many
    sleeps."""

    reason: str
    at: float
    sleeps: int


async def run_watchdog(supervision: Supervision, clock: Clock, sleep: StarvedSleep) -> list[Ended]:
    """The watchdog (0.05 s period) until ``sleep`` has run its ticks; motion is under way until
    the first end."""
    ended: list[Ended] = []

    async def end_motion(reason: str) -> None:
        ended.append(Ended(reason, clock.now, sleep.calls))

    watchdog = asyncio.create_task(
        watch_supervision(
            supervision, end_motion, lambda: not ended, 0.05, clock=clock, sleep=sleep
        )
    )
    try:
        async with asyncio.timeout(5):
            await sleep.done.wait()
    finally:
        watchdog.cancel()
    return ended


def renew(supervision: Supervision) -> Callable[[], object]:
    return lambda: supervision.renew("brain-1", 0.8, latched=False)


async def test_a_lapse_seen_right_after_the_server_was_starved_waits_for_the_unread_renewals() -> (
    None
):
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    sleep = StarvedSleep(clock, ticks=40)
    # the 2nd sleep takes 1.2 s more (the server did not run); the brain's renewals waited in
    # its inbox and are read one period after it woke: the lapse it saw first is not acted on
    sleep.starved[2] = 1.2
    locked_when_woken: list[bool] = []
    sleep.then[2] = lambda: locked_when_woken.append(supervision.locked())
    sleep.then[3] = renew(supervision)
    for tick in range(4, 40, 4):
        sleep.then[tick] = renew(supervision)

    ended = await run_watchdog(supervision, clock, sleep)

    assert ended == []
    assert locked_when_woken == [True]  # the dead-man lock did not wait
    assert not supervision.locked()


async def test_a_lapse_after_starvation_still_ends_motion_once_the_grace_is_over() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    sleep = StarvedSleep(clock, ticks=12)
    sleep.starved[2] = 1.2  # starved, and no renewal was waiting: the brain is gone

    ended = await run_watchdog(supervision, clock, sleep)

    assert [end.reason for end in ended] == [
        "supervision was lost: the supervising brain stopped renewing its lease"
    ]


async def test_without_starvation_a_lapse_ends_motion_at_the_first_look() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    sleep = StarvedSleep(clock, ticks=30)

    ended = await run_watchdog(supervision, clock, sleep)

    # 0.8 s of 0.05 s periods: the look right after the lapse (16, or 17 by float rounding)
    assert len(ended) == 1
    assert ended[0].sleeps in (16, 17)


async def test_a_server_late_on_every_tick_still_ends_motion_soon_after_the_lapse() -> None:
    """A lag on every tick (a busy process) must not extend the grace for ever: a lapse waits
    at most STARVED_GRACE_S and a tick (the CI run of stop 34 caught the unbounded version)."""
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)  # never renewed again: the brain is gone
    sleep = StarvedSleep(clock, ticks=12)
    for tick in range(1, 13):
        sleep.starved[tick] = 0.15  # each 0.05 s sleep takes 0.2 s

    ended = await run_watchdog(supervision, clock, sleep)

    assert len(ended) == 1
    assert ended[0].at - 100.8 <= 0.25 + 0.2 + 1e-6  # the lapse, the grace, one late tick


# -- issue 35: the lease is the brain's alone, alarms, the sweep below -------------------------


class AsPrincipal:
    """Test middleware: every request arrives as ``principal`` had presented its credential."""

    def __init__(self, principal: str) -> None:
        self.principal = principal

    async def __call__(self, ctx: Any, call_next: Any) -> Any:
        request = SimpleNamespace(scope={PRINCIPAL_SCOPE_KEY: self.principal})
        return await CallerContext()(dataclasses.replace(ctx, request=request), call_next)


def motion_server(supervision: Supervision, principal: str | None) -> MCPServer:
    server = MCPServer("motion")
    install_json_tool_errors(server)
    if principal is not None:
        server.middleware.append(AsPrincipal(principal))
    add_supervise_tool(server, supervision)
    return server


@pytest.mark.parametrize("principal", ["operator", "anonymous", "mallory"])
async def test_supervise_from_anyone_but_the_brain_is_not_permitted_and_changes_nothing(
    principal: str, capsys: pytest.CaptureFixture[str]
) -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=True, reason="person in the way")

    async with Client(motion_server(supervision, principal)) as client:
        lifted = await client.call_tool(
            "supervise", {"holder": "brain-1", "latched": False, "ttl_s": 2}
        )

    assert lifted.is_error
    error = parse_tool_error(lifted.content[0].text)  # type: ignore[union-attr]
    assert error is not None
    assert error["error"] == NOT_PERMITTED
    assert principal in error["detail"]
    assert supervision.refusal() is not None  # still latched
    assert supervision.refusal().code == SAFETY_STOP_LATCHED  # type: ignore[union-attr]
    assert supervision.locked()
    logged = capsys.readouterr().out
    assert "supervise_refused" in logged


@pytest.mark.parametrize("principal", ["brain", None])  # None: the in-process (local) parent
async def test_the_brain_and_the_local_parent_still_renew_the_lease(principal: str | None) -> None:
    supervision = Supervision(max_ttl_s=2.0)

    async with Client(motion_server(supervision, principal)) as client:
        ok = await client.call_tool("supervise", {"holder": "brain-1", "latched": False})

    answer = json.loads(ok.content[0].text)  # type: ignore[union-attr]
    assert not ok.is_error
    assert answer["supervised"] is True
    assert answer["lock"] == "open"
    assert answer["alarms"] == []


async def test_another_holder_while_the_lease_is_fresh_is_an_intrusion_alarm() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)

    async with Client(motion_server(supervision, "brain")) as client:
        intruded = await client.call_tool(
            "supervise", {"holder": "x", "latched": False, "ttl_s": 2}
        )
        status = json.loads(
            (await client.call_tool("supervise", {"holder": "brain-1", "latched": False}))
            .content[0]
            .text  # type: ignore[union-attr]
        )

    assert intruded.is_error
    assert parse_tool_error(intruded.content[0].text)["error"] == NOT_PERMITTED  # type: ignore[index,union-attr]
    assert supervision.lease is not None
    assert supervision.lease.holder == "brain-1"
    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == SUPERVISION_ALARM
    assert FOREIGN_HOLDER in refused.detail
    assert supervision.locked()
    assert status["lock"] == "locked"
    assert [a["code"] for a in status["alarms"]] == [FOREIGN_HOLDER]
    assert "someone other than the supervising brain" in status["alarms"][0]["detail"]
    assert isinstance(status["alarms"][0]["at"], float)


def test_a_new_holder_is_taken_without_alarm_after_a_lapse_or_a_release() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=True)
    clock.now += 1.0  # lapsed: the brain restarted
    supervision.renew("brain-2", 0.8, latched=True)
    supervision.release("brain-2")
    supervision.renew("brain-3", 0.8, latched=False)

    assert supervision.alarms() == []
    assert supervision.lease is not None
    assert supervision.lease.holder == "brain-3"


def test_an_alarm_is_acknowledged_only_by_the_holders_latched_renewal_once_its_cause_is_gone() -> (
    None
):
    clock = Clock()
    supervision = supervised(clock, alarm_quiet_s=1.0)
    supervision.renew("brain-1", 0.8, latched=False)
    assert supervision.raise_alarm(LOCK_TOPIC_SHARED, "a second publisher")
    assert not supervision.raise_alarm(LOCK_TOPIC_SHARED, "a second publisher")  # not new

    clock.now += 0.5
    supervision.renew("brain-1", 0.8, latched=True)  # the cause was seen 0.5 s ago: stays
    assert [a.code for a in supervision.alarms()] == [LOCK_TOPIC_SHARED]
    clock.now += 0.6
    supervision.renew("brain-1", 0.8, latched=False)  # not latched: no acknowledgement
    assert [a.code for a in supervision.alarms()] == [LOCK_TOPIC_SHARED]
    supervision.renew("brain-1", 0.8, latched=True)

    assert supervision.alarms() == []
    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == SAFETY_STOP_LATCHED  # the brain's latch


def test_a_standing_condition_keeps_its_alarm_through_every_acknowledgement() -> None:
    clock = Clock()
    supervision = supervised(clock)
    for _ in range(10):
        supervision.raise_alarm(POSE_TOPIC_SHARED, "a second publisher on /amcl_pose")
        supervision.renew("brain-1", 0.8, latched=True)
        clock.now += 0.2
    assert [a.code for a in supervision.alarms()] == [POSE_TOPIC_SHARED]


def test_after_a_stop_the_lock_opens_only_once_the_goals_below_were_swept() -> None:
    clock = Clock()
    supervision = supervised(clock, sweeps=True)
    supervision.renew("brain-1", 0.8, latched=False)
    assert supervision.sweep_due() is None
    assert not supervision.locked()

    supervision.renew("brain-1", 0.8, latched=True)
    assert supervision.sweep_due() is None  # owed, but only once the stop ended
    supervision.renew("brain-1", 0.8, latched=False)  # Clear stop
    stops = supervision.sweep_due()
    assert stops is not None

    assert supervision.locked()
    refused = supervision.refusal()
    assert refused is not None
    assert refused.code == SAFETY_STOP_LATCHED
    assert supervision.status()["latched"] is True  # the brain waits for this to turn false
    supervision.mark_swept(stops)
    assert not supervision.locked()
    assert supervision.refusal() is None


def test_a_lapse_is_a_stop_whose_sweep_comes_before_the_lock_opens_again() -> None:
    clock = Clock()
    supervision = supervised(clock, sweeps=True)
    supervision.renew("brain-1", 0.8, latched=False)
    clock.now += 1.0
    supervision.renew("brain-1", 0.8, latched=False)  # back after a lapse

    due = supervision.sweep_due()
    assert due is not None
    assert supervision.locked()
    supervision.mark_swept(due)
    assert not supervision.locked()


async def test_the_watchdog_cancels_every_goal_below_on_a_stop_and_again_before_reopening() -> None:
    clock = Clock()
    supervision = supervised(clock, sweeps=True)
    supervision.renew("brain-1", 0.8, latched=False)
    swept: list[bool] = []

    async def cancel_all() -> bool:
        swept.append(supervision.locked())
        return True

    assert supervision.sweep_due() is None

    async def end_motion(reason: str) -> None:
        return None

    watchdog = asyncio.create_task(
        watch_supervision(
            supervision, end_motion, lambda: False, period_s=0.005, cancel_all=cancel_all
        )
    )
    try:
        supervision.renew("brain-1", 0.8, latched=True)
        await async_wait(lambda: len(swept) >= 1)
        supervision.renew("brain-1", 0.8, latched=False)
        await async_wait(lambda: not supervision.locked())
    finally:
        watchdog.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await watchdog

    assert len(swept) == 2  # once on the latch, once after the clear before the lock opened
    assert swept == [True, True]  # locked both times


async def test_an_alarm_ends_running_motion_at_once_naming_it() -> None:
    clock = Clock()
    supervision = supervised(clock)
    supervision.renew("brain-1", 0.8, latched=False)
    sleep = StarvedSleep(clock, ticks=6)  # 0.3 s on the fake clock: the lease holds throughout
    sleep.then[3] = lambda: supervision.raise_alarm(
        LOCK_TOPIC_SHARED, "another node publishes the lock topic"
    )

    ended = await run_watchdog(supervision, clock, sleep)

    assert [e.sleeps for e in ended] == [3]  # the first look after the alarm, not before it
    assert ended[0].reason.startswith("supervision raised an alarm")
    assert "LOCK_TOPIC_SHARED" in ended[0].reason


async def async_wait(condition: Callable[[], bool], timeout_s: float = 5.0) -> None:
    async with asyncio.timeout(timeout_s):
        while not condition():  # noqa: ASYNC110 - polls state the watchdog changes
            await asyncio.sleep(0.002)
