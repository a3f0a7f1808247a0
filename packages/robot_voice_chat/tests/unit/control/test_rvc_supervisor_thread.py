"""The lease on its own thread or in its own process (issue 39; the process's code run by
``rvc_lease_fakes.PipeOnThread``) and supervision alarms (issue 35): a blocked brain loop
does not stop the renewals; an alarm in a ``supervise`` answer latches the stop at once, names
it and is told once; a ``not_permitted`` answer is told once."""

from __future__ import annotations

import json
import threading
from collections.abc import AsyncIterator, Callable
from typing import Any

import pytest

from robot_stack_testing import async_wait_until, wait_until
from robot_voice_chat.control.alarms import (
    AlarmAnnouncer,
    SupervisionNotice,
    alarm_reason,
    alarm_told,
    parse_alarms,
)
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import leaks
from robot_voice_chat.services.tools.base import ToolOutcome
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import McpServerConfig

NAV = McpServerConfig(name="navigation", url="http://127.0.0.1:9/sse", motion=True)
RUNNERS = ["thread", "process"]  # the process's code faked on a thread: conftest.PipeOnThread
LOCK_ALARM = {
    "code": "LOCK_TOPIC_SHARED",
    "detail": "A second process publishes on /robot/supervisor_lock.",
    "at": 1700000000.0,
}


class Server:
    """A motion server's supervise tool, answered on whatever thread calls it."""

    def __init__(self) -> None:
        self.leases: list[dict[str, Any]] = []
        self.threads: set[str] = set()
        self.alarms: list[dict[str, Any]] = []
        self.refuse = False
        self.down = False
        self.renewed = threading.Event()
        self._lock = threading.Lock()

    def supervise(self, arguments: dict[str, Any]) -> Any:
        with self._lock:
            self.leases.append(arguments)
            self.threads.add(threading.current_thread().name)
        self.renewed.set()
        if self.down:
            return ToolOutcome(text="error: navigation.supervise failed: closed", is_error=True)
        if self.refuse:
            body = {"error": "not_permitted", "detail": "supervise is the brain's alone"}
            return ToolOutcome(text=json.dumps(body), is_error=True)
        latched = bool(arguments["latched"])
        alarms = list(self.alarms)
        if latched and self.alarms:  # a latched renewal acknowledges an alarm whose cause is gone
            alarms = [a for a in alarms if not a.get("gone")]
            self.alarms = alarms
        return {
            "supervised": True,
            "latched": latched,
            "lock": "locked" if latched or alarms else "open",
            "alarms": alarms,
        }

    def count(self) -> int:
        with self._lock:
            return len(self.leases)


def backend(server: Server) -> FakeToolBackend:
    tools = FakeToolBackend([NAV])
    tools.add("navigation.supervise", server.supervise, holder="string", latched="boolean")
    return tools


@pytest.fixture
def server() -> Server:
    return Server()


@pytest.fixture
def latch() -> SafetyLatch:
    return SafetyLatch(MemoryLatchStore())


class Told:
    def __init__(self) -> None:
        self.said: list[str] = []
        self.stops: list[str] = []

    async def tell(self, text: str) -> None:
        self.said.append(text)

    async def stop(self, reason: str) -> None:
        self.stops.append(reason)


@pytest.fixture(params=RUNNERS)
async def threaded(
    server: Server,
    latch: SafetyLatch,
    request: pytest.FixtureRequest,
    make_supervisor: Callable[..., MotionSupervisor],
) -> AsyncIterator[tuple[MotionSupervisor, Told]]:
    told = Told()
    supervisor = make_supervisor(
        request.param,
        backend(server),  # the brain's backend: never used for the lease here
        lambda: backend(server),
        latch,
        period_s=0.1,
        ttl_s=2.0,
        holder="brain-test",
        on_notice=AlarmAnnouncer(stop=told.stop, tell=told.tell),
    )
    await supervisor.start()
    yield supervisor, told
    await supervisor.aclose()


async def test_renewals_go_on_while_the_brain_loop_is_blocked(
    threaded: tuple[MotionSupervisor, Told], server: Server
) -> None:
    supervisor, _ = threaded
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")
    before = server.count()

    # the brain's loop does not run at all until three more renewals reached the server
    wait_until(lambda: server.count() >= before + 3, 10, "renewals while the loop is blocked")

    assert server.threads == {"supervision"}
    assert supervisor.summary()["runner"] in ("thread", "process")


@pytest.mark.parametrize("runner", RUNNERS)
async def test_a_latch_wakes_the_renewal_thread_at_once(
    server: Server,
    latch: SafetyLatch,
    runner: str,
    make_supervisor: Callable[..., MotionSupervisor],
) -> None:
    supervisor = make_supervisor(
        runner, backend(server), lambda: backend(server), latch, period_s=3.0, ttl_s=6.0
    )
    await supervisor.start()
    try:
        await async_wait_until(lambda: server.leases, 5, "a first renewal")
        await latch.stop("operator", "person in the way")
        await async_wait_until(
            lambda: server.leases[-1]["latched"], 2.0, "the latched lease before the period ends"
        )
        assert server.leases[-1]["reason"] == "person in the way"
        await latch.clear("operator", "checked")
        assert await supervisor.ensure_fresh("navigation", timeout_s=2.0)
        assert server.leases[-1]["latched"] is False
        assert await supervisor.wait_lock_open("navigation", timeout_s=2.0)
    finally:
        await supervisor.aclose()


async def test_an_alarm_latches_the_stop_names_it_and_is_told_once(
    threaded: tuple[MotionSupervisor, Told], server: Server, latch: SafetyLatch
) -> None:
    supervisor, told = threaded
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")
    server.alarms = [dict(LOCK_ALARM)]

    await async_wait_until(lambda: latch.latched, 5, "the latch")
    await async_wait_until(lambda: told.said, 5, "the operator told")
    seen = server.count()
    await async_wait_until(lambda: server.count() >= seen + 5, 5, "more renewals")

    state = latch.state
    assert state.by == "the robot's supervision"
    assert state.reason == "another program is publishing on the motion lock of my navigation"
    assert told.stops[:1] == [state.reason]
    assert told.said == [
        "Someone else tried to move me, so I stopped. Another program is publishing on the "
        "motion lock of my navigation. Check the robot's computer, then clear the stop."
    ]
    assert server.leases[-1]["latched"] is True  # every renewal since carries the stop
    assert supervisor.alarms() == [{"server": "navigation", **LOCK_ALARM}]
    assert not supervisor.lock_open("navigation")


async def test_an_alarm_whose_cause_is_gone_is_acknowledged_and_the_latch_stays(
    threaded: tuple[MotionSupervisor, Told], server: Server, latch: SafetyLatch
) -> None:
    supervisor, told = threaded
    server.alarms = [dict(LOCK_ALARM, gone=True)]

    await async_wait_until(lambda: latch.latched, 5, "the latch")
    await async_wait_until(lambda: not server.alarms, 5, "the alarm acknowledged")
    await async_wait_until(lambda: not supervisor.alarms(), 5, "no alarm reported")

    assert latch.latched  # only the operator's Clear stop lifts it
    assert len(told.said) == 1


async def test_the_stop_is_carried_even_before_the_brain_loop_latches(
    threaded: tuple[MotionSupervisor, Told], server: Server, latch: SafetyLatch
) -> None:
    """The renewal thread sends ``latched`` itself: a busy brain loop does not delay it."""
    supervisor, _ = threaded
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")
    server.alarms = [dict(LOCK_ALARM)]
    seen = server.count()

    wait_until(
        lambda: any(lease["latched"] for lease in server.leases[seen:]),
        10,
        "a latched renewal while the brain's loop is blocked",
    )

    assert not latch.latched  # the loop has not run yet; it latches once it does
    await async_wait_until(lambda: latch.latched, 5, "the latch")


async def test_a_refused_lease_is_told_once_and_not_latched(
    threaded: tuple[MotionSupervisor, Told], server: Server, latch: SafetyLatch
) -> None:
    supervisor, told = threaded
    server.refuse = True
    seen = server.count()

    await async_wait_until(lambda: server.count() >= seen + 5, 5, "refused renewals")
    await async_wait_until(lambda: told.said, 5, "the operator told")

    assert told.said == [
        "My navigation refuses my safety lease, so it will not move. The credential I use for "
        "it is not the one it accepts: the robot's settings need checking."
    ]
    assert supervisor.summary()["servers"]["navigation"]["state"] == "refused"
    assert not latch.latched


async def test_without_a_handler_an_alarm_still_latches_and_persists(
    server: Server,
) -> None:
    store = MemoryLatchStore()
    latch = SafetyLatch(store)
    server.alarms = [{"code": "POSE_TOPIC_SHARED", "detail": "x", "at": 1.0}]
    supervisor = MotionSupervisor(backend(server), latch, period_s=0.05, ttl_s=0.5)
    await supervisor.start()
    try:
        await async_wait_until(lambda: store.journal, 5, "the latch persisted")
    finally:
        await supervisor.aclose()
    assert store.journal[-1]["reason"] == "another program is publishing a position for me"


def test_alarm_words_are_plain_for_every_code() -> None:
    codes = [
        "FOREIGN_HOLDER",
        "LOCK_TOPIC_SHARED",
        "POSE_TOPIC_SHARED",
        "MAP_TOPIC_SHARED",
        "FOREIGN_GOAL_CLIENT",
        "SOMETHING_NEW",
    ]
    for code in codes:
        alarms = parse_alarms("navigation", {"alarms": [{"code": code, "detail": "d", "at": 1}]})
        assert alarms[0].code == code
        assert leaks(alarm_told(alarms)) == [], code
        assert leaks(alarm_reason(alarms)) == [], code
    garbled = parse_alarms("manipulation", {"alarms": ["?"]})
    assert garbled[0].code == "UNKNOWN"
    assert "arm" in alarm_told(garbled)


async def test_the_announcer_tells_each_alarm_once() -> None:
    told = Told()
    announcer = AlarmAnnouncer(stop=told.stop, tell=told.tell)
    [alarm] = parse_alarms("navigation", {"alarms": [LOCK_ALARM]})
    notice = SupervisionNotice("alarms", "navigation", (alarm,), "why")

    await announcer(notice)
    await announcer(notice)

    assert told.stops == ["why", "why"]
    assert len(told.said) == 1


async def test_stopping_ends_the_thread(server: Server, latch: SafetyLatch) -> None:
    supervisor = MotionSupervisor(
        backend(server), latch, period_s=0.05, ttl_s=0.5, lease_tools=lambda: backend(server)
    )
    await supervisor.start()
    await async_wait_until(lambda: server.leases, 5, "a renewal")
    await supervisor.aclose()
    assert not any(t.name == "supervision" for t in threading.enumerate())


class Brain(FakeToolBackend):
    """The brain's own backend: records when it is asked to check a server now."""

    def __init__(self, server: Server) -> None:
        super().__init__([NAV])
        self.add("navigation.supervise", server.supervise, holder="string")
        self.checked: list[tuple[str, str]] = []

    def check_now(self, server: str) -> None:
        self.checked.append((server, threading.current_thread().name))


@pytest.mark.parametrize("runner", RUNNERS)
async def test_a_lost_server_is_checked_at_once_by_the_brains_own_connection(
    server: Server,
    latch: SafetyLatch,
    runner: str,
    make_supervisor: Callable[..., MotionSupervisor],
) -> None:
    """The lease's connection notices a dead motion server first: the brain's connection is
    told to check it now (a mission hears of the loss without waiting for a health check),
    on the brain's own loop."""
    brain = Brain(server)
    supervisor = make_supervisor(
        runner, brain, lambda: backend(server), latch, period_s=0.05, ttl_s=0.5
    )
    await supervisor.start()
    try:
        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")
        server.down = True
        await async_wait_until(lambda: brain.checked, 5, "the brain's connection checked")
    finally:
        await supervisor.aclose()

    assert brain.checked[0] == ("navigation", threading.current_thread().name)
    assert supervisor.summary()["servers"]["navigation"]["state"] == "unreachable"


async def test_a_hung_brain_loop_stops_the_renewals(server: Server, latch: SafetyLatch) -> None:
    """Busy is not hung: renewals go on while the loop is busy (above), but once it has not run
    for ``hung_after_s`` the thread stops renewing and the lease lapses as for a dead brain."""
    supervisor = MotionSupervisor(
        backend(server),
        latch,
        period_s=0.05,
        ttl_s=0.5,
        lease_tools=lambda: backend(server),
        hung_after_s=1.0,
    )
    await supervisor.start()
    try:
        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")

        # the brain's loop is blocked from here on (a deadlock, as far as the thread can tell)
        wait_until(supervisor.brain_hung, 10, "the brain's loop seen hung")
        wait_until(
            lambda: supervisor.summary()["servers"]["navigation"]["state"] == "unreachable",
            10,
            "the lease let go",
        )
        seen, ticks = server.count(), supervisor._ticks
        wait_until(lambda: supervisor._ticks >= ticks + 3, 10, "three more renewal rounds")
        assert server.count() == seen  # none of them renewed

        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "renewed once it runs")
    finally:
        await supervisor.aclose()
