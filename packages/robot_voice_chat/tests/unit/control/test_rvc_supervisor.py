"""MotionSupervisor (issue 27): the brain renews a lease on every motion server with its latch
state, pushes a latch at once, and knows when a server it cannot reach has lapsed."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest

from robot_stack_testing import async_wait_until
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.tools.base import ToolOutcome
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import McpServerConfig


class Server:
    """A motion server's supervise tool: answers like robot_mcp_kit's, or not at all."""

    def __init__(self) -> None:
        self.reachable = True
        self.leases: list[dict[str, Any]] = []

    def supervise(self, arguments: dict[str, Any]) -> Any:
        if not self.reachable:
            return ToolOutcome(text="error: navigation.supervise failed: closed", is_error=True)
        self.leases.append(arguments)
        return {"supervised": True, "latched": arguments["latched"], "lock": "open"}


@pytest.fixture
def server() -> Server:
    return Server()


@pytest.fixture
def tools(server: Server) -> FakeToolBackend:
    backend = FakeToolBackend(
        [McpServerConfig(name="navigation", url="http://127.0.0.1:9/sse", motion=True)]
    )
    backend.add("navigation.supervise", server.supervise, holder="string", latched="boolean")
    backend.add("navigation.navigate_to", lambda a: {"task_id": "nav-1"}, location="string")
    backend.add("memory.supervise", lambda a: {"supervised": True})  # not a motion server
    return backend


@pytest.fixture
def latch() -> SafetyLatch:
    return SafetyLatch(MemoryLatchStore())


@pytest.fixture
async def supervisor(tools: FakeToolBackend, latch: SafetyLatch) -> AsyncIterator[MotionSupervisor]:
    supervisor = MotionSupervisor(tools, latch, period_s=0.05, ttl_s=0.2, holder="brain-test")
    await supervisor.start()
    yield supervisor
    await supervisor.aclose()


async def test_every_motion_server_gets_a_lease_carrying_the_latch(
    supervisor: MotionSupervisor, server: Server, tools: FakeToolBackend
) -> None:
    await async_wait_until(lambda: len(server.leases) >= 3, 5, "three renewals")

    assert server.leases[0] == {
        "holder": "brain-test",
        "latched": False,
        "ttl_s": 0.2,
        "reason": "",
    }
    assert supervisor.fresh("navigation")
    assert tools.called("memory.supervise") == []  # only motion servers are supervised


async def test_a_latch_reaches_the_server_at_once_not_at_the_next_period(
    tools: FakeToolBackend, latch: SafetyLatch, server: Server
) -> None:
    supervisor = MotionSupervisor(tools, latch, period_s=3.0, ttl_s=6.0)
    await supervisor.start()
    try:
        await async_wait_until(lambda: server.leases, 5, "a first renewal")
        await latch.stop("operator", "person in the way")
        await async_wait_until(
            lambda: server.leases[-1]["latched"], 2.0, "the latched lease before the period ends"
        )
        assert server.leases[-1]["reason"] == "person in the way"
    finally:
        await supervisor.aclose()


async def test_a_motion_call_right_after_a_clear_waits_until_the_server_heard_it(
    tools: FakeToolBackend, latch: SafetyLatch, server: Server
) -> None:
    """The CI failure of stop 33: "continue" right after Clear stop met the server's old latch
    (SAFETY_STOP_LATCHED) because the lease was fresh but still carried the latch."""
    supervisor = MotionSupervisor(tools, latch, period_s=3.0, ttl_s=6.0)
    await supervisor.start()
    try:
        await latch.stop("operator", "person in the way")
        await async_wait_until(lambda: server.leases and server.leases[-1]["latched"], 5, "latched")
        await latch.clear("operator", "checked")
        assert await supervisor.ensure_fresh("navigation", timeout_s=2.0)
        assert server.leases[-1]["latched"] is False  # heard before the call may go
    finally:
        await supervisor.aclose()


class SweepingServer(Server):
    """After a clear it answers ``latched`` with its lock locked for a few renewals: it is
    cancelling every goal below it first (issue 35's sweep), as robot_mcp_kit does."""

    def __init__(self, sweeping_renewals: int) -> None:
        super().__init__()
        self.sweeping_renewals = sweeping_renewals
        self.was_latched = False
        self.owed = 0

    def supervise(self, arguments: dict[str, Any]) -> Any:
        self.leases.append(arguments)
        if self.was_latched and not arguments["latched"]:
            self.owed = self.sweeping_renewals
        self.was_latched = arguments["latched"]
        if self.owed:
            self.owed -= 1
            return {"supervised": True, "latched": True, "lock": "locked"}
        return {"supervised": True, "latched": arguments["latched"], "lock": "open"}


async def test_a_motion_call_right_after_a_clear_waits_for_the_servers_sweep(
    latch: SafetyLatch,
) -> None:
    """The CI failure of stop 40: "continue" right after Clear stop was refused with "the stop
    was cleared a moment ago" while navigation still swept the goals below it."""
    sweeping = SweepingServer(sweeping_renewals=4)
    backend = FakeToolBackend(
        [McpServerConfig(name="navigation", url="http://127.0.0.1:9/sse", motion=True)]
    )
    backend.add("navigation.supervise", sweeping.supervise, holder="string", latched="boolean")
    supervisor = MotionSupervisor(backend, latch, period_s=0.05, ttl_s=0.5)
    await supervisor.start()
    try:
        await latch.stop("operator", "person in the way")
        await async_wait_until(lambda: sweeping.was_latched, 5, "latched")
        await latch.clear("operator", "checked")

        assert await supervisor.ready_for_motion("navigation", timeout_s=5.0)

        assert sweeping.owed == 0  # every sweeping answer came before it said ready
        assert supervisor.lock_open("navigation")
    finally:
        await supervisor.aclose()


async def test_ready_for_motion_answers_at_once_while_latched_or_unsupervised(
    supervisor: MotionSupervisor, latch: SafetyLatch
) -> None:
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "supervised")
    assert await supervisor.ready_for_motion("memory", timeout_s=30) is False
    await latch.stop("operator", "person in the way")
    assert await supervisor.ready_for_motion("navigation", timeout_s=30) is False


async def test_a_server_that_stops_answering_lapses_one_ttl_after_its_last_renewal(
    supervisor: MotionSupervisor, server: Server
) -> None:
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "supervised")
    server.reachable = False

    outcome, lapsed_at = await supervisor.settle("navigation")

    assert outcome == "lapsed"
    assert lapsed_at > 0
    assert not supervisor.fresh("navigation")
    assert supervisor.summary()["servers"]["navigation"]["state"] == "unreachable"


async def test_a_server_that_keeps_answering_has_taken_the_latch(
    supervisor: MotionSupervisor, latch: SafetyLatch
) -> None:
    await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "supervised")
    latch.engage("operator", "stop")

    assert await supervisor.settle("navigation") == ("latched", 0.0)


def test_a_lease_period_longer_than_half_the_ttl_is_refused(
    tools: FakeToolBackend, latch: SafetyLatch
) -> None:
    with pytest.raises(ValueError, match="half"):
        MotionSupervisor(tools, latch, period_s=0.5, ttl_s=0.8)


async def test_no_planner_or_caller_behind_the_guard_sees_or_sends_the_lease(
    tools: FakeToolBackend, latch: SafetyLatch, server: Server
) -> None:
    guarded = GuardedToolBackend(tools, latch)

    names = [t.name for t in guarded.list_tools()]
    refused = await guarded.call_tool("navigation.supervise", {"holder": "x", "latched": False})

    assert "navigation.supervise" not in names
    assert not guarded.has_tool("navigation.supervise")
    assert refused.is_error
    assert "reserved for the robot's supervisor" in refused.text
    assert server.leases == []


async def test_a_motion_call_right_after_a_reconnect_waits_for_the_first_lease(
    tools: FakeToolBackend, latch: SafetyLatch, server: Server
) -> None:
    tools.states["navigation"] = "disconnected"
    supervisor = MotionSupervisor(tools, latch, period_s=2.0, ttl_s=5.0)  # renewals far apart
    await supervisor.start()
    try:
        await async_wait_until(
            lambda: supervisor.summary()["servers"]["navigation"]["state"] == "unreachable",
            5,
            "no lease while disconnected",
        )
        tools.states["navigation"] = "connected"
        guarded = GuardedToolBackend(tools, latch, supervisor=supervisor)

        await guarded.call_tool("navigation.navigate_to", {"location": "kitchen"})
    finally:
        await supervisor.aclose()

    order = [name for name, _ in tools.calls if name.startswith("navigation.")]
    assert order.index("navigation.supervise") < order.index("navigation.navigate_to")


async def test_a_motion_server_without_a_lease_tool_is_not_counted_nor_waited_for(
    tools: FakeToolBackend, latch: SafetyLatch, server: Server
) -> None:
    arm = McpServerConfig(name="manipulation", url="http://127.0.0.1:9/sse", motion=True)
    backend = FakeToolBackend([*tools.servers().values(), arm])
    backend.add("navigation.supervise", server.supervise, holder="string")
    backend.add("manipulation.pick", lambda a: {"task_id": "pick-1"}, label="string")
    supervisor = MotionSupervisor(backend, latch, period_s=0.05, ttl_s=0.2)
    await supervisor.start()
    try:
        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "navigation leased")
        await async_wait_until(
            lambda: supervisor.summary()["servers"]["manipulation"]["state"] == "unsupported",
            5,
            "the arm's server seen without a lease tool",
        )

        assert supervisor.all_fresh()
        assert await supervisor.ensure_fresh("manipulation", timeout_s=60) is False
    finally:
        await supervisor.aclose()
