"""The lease renewals in a child process (issue 39, ``control.lease_runner: process``): the pipe's
messages, a hung brain, and the real process: its credentials never on its command line, it
exits at once when the brain's end of the pipe closes (a brain killed with -9), it is started
again if it dies under a living brain, and the brain ends it on shutdown."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from robot_stack_testing import async_wait_until, free_tcp_port, wait_until
from robot_voice_chat.composition import bootstrap, compose_config
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.lease_child import MirrorLatch
from robot_voice_chat.control.lease_link import CHILD_MODULE, LeaseProcess, server_payload
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import McpServerConfig

# a motion server's brain credential (never on a command line)
TOKEN = "brain-credential-0123456789-abcdef-0123456789"
BACKEND = {"connect_timeout_s": 1.0, "reconnect_interval_s": 0.5, "call_timeout_s": 0.5}
LOCK_ALARM = {"code": "LOCK_TOPIC_SHARED", "detail": "A second publisher.", "at": 1.0}


class Server:
    def __init__(self) -> None:
        self.leases: list[dict[str, Any]] = []
        self.alarms: list[dict[str, Any]] = []
        self._lock = threading.Lock()

    def supervise(self, arguments: dict[str, Any]) -> Any:
        with self._lock:
            self.leases.append(arguments)
        latched = bool(arguments["latched"])
        return {"supervised": True, "latched": latched, "lock": "open", "alarms": self.alarms}

    def count(self) -> int:
        with self._lock:
            return len(self.leases)


def nav(port: int = 9) -> McpServerConfig:
    return McpServerConfig.model_validate(
        {
            "name": "navigation",
            "url": f"http://127.0.0.1:{port}/sse",
            "motion": True,
            "auth_token": TOKEN,
        }
    )


def backend(server: Server) -> FakeToolBackend:
    tools = FakeToolBackend([nav()])
    tools.add("navigation.supervise", server.supervise, holder="string", latched="boolean")
    return tools


@pytest.fixture
def latch() -> SafetyLatch:
    return SafetyLatch(MemoryLatchStore())


async def test_the_brain_mirrors_the_processs_views_and_pushes_its_latch_first(
    latch: SafetyLatch, make_supervisor: Callable[..., MotionSupervisor]
) -> None:
    server = Server()
    supervisor = make_supervisor(
        "process", backend(server), lambda: backend(server), latch, period_s=0.1, ttl_s=2.0
    )
    await supervisor.start()
    link = supervisor._link
    try:
        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")
        view = supervisor.view("navigation")
        sent = [m for m in link.sent_up("view") if m["state"] == "supervised"][-1]
        assert view is not None
        assert view.renewed_at is not None
        assert view.renewed_wall is not None
        assert view.server_latched is False
        assert view.lock == "open"
        assert supervisor.summary()["runner"] == "process"
        assert supervisor.renewal_summary()["n"] >= 0
        assert sent["server"] == "navigation"

        latch.engage("operator", "a person in the way")  # no listener has run yet
        supervisor.wake("navigation")
        await async_wait_until(lambda: server.leases[-1]["latched"], 5, "a latched renewal")
        down = link.down
        kinds = [m["t"] for m in down]
        assert down[kinds.index("latch")] == {
            "t": "latch",
            "latched": True,
            "reason": "a person in the way",
        }
        assert kinds.index("latch") < len(kinds) - 1 - kinds[::-1].index("wake")
        assert server.leases[-1]["reason"] == "a person in the way"
    finally:
        await supervisor.aclose()


async def test_an_alarm_reaches_the_brain_which_latches_and_the_process_carries_it(
    latch: SafetyLatch, make_supervisor: Callable[..., MotionSupervisor]
) -> None:
    server = Server()
    server.alarms = [LOCK_ALARM]
    supervisor = make_supervisor(
        "process", backend(server), lambda: backend(server), latch, period_s=0.1, ttl_s=2.0
    )
    await supervisor.start()
    link = supervisor._link
    try:
        await async_wait_until(lambda: latch.latched, 5, "the brain's latch")
        await async_wait_until(
            lambda: any(m["t"] == "alarm_taken" for m in link.down),
            5,
            "the process told the alarm is latched",
        )
        assert supervisor.alarms() == [{"server": "navigation", **LOCK_ALARM}]
        assert (
            latch.state.reason
            == "another program is publishing on the motion lock of my navigation"
        )
        assert len(link.sent_up("alarm_seen")) == 1
        seen = server.count()
        await async_wait_until(lambda: server.count() >= seen + 3, 5, "more renewals")
        assert all(lease["latched"] for lease in server.leases[seen:])
    finally:
        await supervisor.aclose()


async def test_a_hung_brain_loop_stops_the_processs_renewals(
    latch: SafetyLatch, make_supervisor: Callable[..., MotionSupervisor]
) -> None:
    """The process hears the brain's heartbeat; silent ``hung_after_s``, it lets the lease go."""
    server = Server()
    supervisor = make_supervisor(
        "process",
        backend(server),
        lambda: backend(server),
        latch,
        period_s=0.05,
        ttl_s=0.5,
        hung_after_s=1.0,
    )
    await supervisor.start()
    link = supervisor._link
    try:
        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "a first lease")

        # the brain's loop is blocked from here on: no heartbeat goes down the pipe
        wait_until(
            lambda: link.sent_up("view")[-1]["state"] == "unreachable",
            10,
            "the lease let go",
        )
        assert "hung" in link.sent_up("view")[-1]["detail"]
        seen, rounds = server.count(), len(link.sent_up("renewed"))
        wait_until(
            lambda: len(link.sent_up("renewed")) >= rounds + 3,
            10,
            "three more renewal rounds",
        )
        assert server.count() == seen  # none of them renewed

        await async_wait_until(lambda: supervisor.fresh("navigation"), 5, "renewed once it runs")
    finally:
        await supervisor.aclose()


def test_the_mirror_latch_takes_the_brains_latch() -> None:
    latch = MirrorLatch()
    assert latch.mirror(True, "why")
    assert not latch.mirror(True, "why")
    assert latch.state.reason == "why"
    assert latch.mirror(False, "")
    assert not latch.latched


def test_the_credential_goes_down_the_pipe_in_clear() -> None:
    assert server_payload(nav())["auth_token"] == TOKEN


def cmdline(pid: int) -> str:
    return Path(f"/proc/{pid}/cmdline").read_text()


def child() -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", CHILD_MODULE], stdin=subprocess.PIPE, stdout=subprocess.PIPE
    )


def init_line(port: int) -> bytes:
    init = {
        "t": "init",
        "holder": "brain-test",
        "period_s": 0.1,
        "ttl_s": 0.5,
        "hung_after_s": 5.0,
        "latched": False,
        "reason": "",
        "servers": [server_payload(nav(port))],
        "backend": {**BACKEND, "quiet_tools": ["supervise"]},
    }
    return json.dumps(init).encode() + b"\n"


@pytest.mark.slow
def test_the_process_exits_at_once_when_the_brains_pipe_closes() -> None:
    """A brain killed with -9 closes its end of the pipe: the process must not outlive it."""
    with child() as process:
        try:
            assert process.stdin is not None
            assert process.stdout is not None
            process.stdin.write(init_line(free_tcp_port()))
            process.stdin.flush()
            kinds = []
            while "ready" not in kinds:  # views and timings may come before
                kinds.append(json.loads(process.stdout.readline())["t"])
            assert "failed" not in kinds
            assert TOKEN not in Path(f"/proc/{process.pid}/cmdline").read_text()

            process.stdin.close()  # what the kernel does when the brain is killed

            assert process.wait(timeout=10) == 0
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()


@pytest.mark.slow
async def test_the_brain_restarts_a_dead_process_and_ends_it_on_shutdown(
    latch: SafetyLatch,
) -> None:
    brain = FakeToolBackend([nav(free_tcp_port())])
    link = LeaseProcess([nav(free_tcp_port())], BACKEND)
    supervisor = MotionSupervisor(brain, latch, period_s=0.1, ttl_s=0.5, lease_process=link)
    await supervisor.start()
    first = link.pid
    try:
        assert first is not None
        assert TOKEN not in cmdline(first)
        await async_wait_until(
            lambda: (
                supervisor.summary()["servers"]["navigation"]["detail"]
                == "connecting to navigation"
            ),
            10,
            "the process reports the server it cannot reach yet",
        )
        os.kill(first, 9)  # the process dies under a living brain
        await async_wait_until(lambda: link.pid not in (None, first), 20, "a new process")
    finally:
        await supervisor.aclose()
    second = link.pid
    assert second is not None
    with pytest.raises(ProcessLookupError):
        os.kill(second, 0)  # ended (and reaped) on shutdown


@pytest.mark.parametrize(
    ("overrides", "runner"), [([], "thread"), (["control.lease_runner=process"], "process")]
)
def test_the_composition_root_runs_the_lease_where_the_settings_say(
    overrides: list[str], runner: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path))
    monkeypatch.setenv("RVC_NAVIGATION_URL", "http://127.0.0.1:9/sse")
    container = bootstrap(compose_config("dev", overrides))
    assert container.supervisor is not None
    assert container.supervisor.runner == runner
