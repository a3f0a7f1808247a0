"""The shared plugin keeps ROS on loopback and stops what tests start."""

from __future__ import annotations

import asyncio
import os
import random
import socket
import subprocess
import sys
import time
from pathlib import Path
from xml.etree import ElementTree

import pytest

from robot_stack_testing import (
    ProcessLauncher,
    async_wait_until,
    free_tcp_port,
    wait_for_tcp_port,
    wait_until,
)
from robot_stack_testing.domains import (
    FIRST_ID,
    LAST_ID,
    NoFreeDomainError,
    claim_domain_id,
    release_domain_id,
)
from robot_stack_testing.plugin import TEST_PROFILE, pick_ros_domain_id, pytest_configure


def test_every_run_discovers_only_on_loopback_in_its_own_domain(ros_domain_id: int) -> None:
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert 1 <= ros_domain_id <= 100
    assert os.environ["ROS_DOMAIN_ID"] == str(ros_domain_id)


def test_a_fast_dds_profile_or_static_peers_from_the_shell_are_dropped_for_the_run(
    monkeypatch: pytest.MonkeyPatch, pytestconfig: pytest.Config
) -> None:
    for name in (
        "ROS_STATIC_PEERS",
        "FASTDDS_DEFAULT_PROFILES_FILE",
        "FASTRTPS_DEFAULT_PROFILES_FILE",
    ):
        monkeypatch.setenv(name, "/etc/robot/fastdds.xml")
    # restored after the test: configuring again draws a new domain id
    monkeypatch.setenv("ROS_DOMAIN_ID", os.environ["ROS_DOMAIN_ID"])
    pytest_configure(pytestconfig)
    assert "ROS_STATIC_PEERS" not in os.environ
    assert os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(TEST_PROFILE)
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ


def test_the_tests_profile_only_shortens_a_reliable_writers_heartbeat() -> None:
    profiles = ElementTree.parse(TEST_PROFILE).getroot()
    ns = {"dds": "http://www.eprosima.com"}
    section = profiles.find("dds:profiles", ns)
    assert section is not None
    assert [child.tag.split("}")[1] for child in section] == ["data_writer"]
    period = profiles.find(".//dds:data_writer/dds:times/dds:heartbeat_period", ns)
    assert period is not None
    sec, nanosec = period.findtext("dds:sec", "", ns), period.findtext("dds:nanosec", "", ns)
    assert int(sec) + int(nanosec) / 1e9 == 0.1


def test_domain_override_wins_over_random_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROBOT_TEST_ROS_DOMAIN_ID", "42")
    assert pick_ros_domain_id() == 42


def test_random_domain_ignores_the_robots_own_domain(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROBOT_TEST_ROS_DOMAIN_ID", raising=False)
    monkeypatch.setenv("ROS_DOMAIN_ID", "0")
    picked = [pick_ros_domain_id() for _ in range(5)]
    for domain in picked:
        release_domain_id(domain)  # claimed for this process: given back for other runs
    assert all(1 <= domain <= 100 for domain in picked)
    assert len(set(picked)) == len(picked)


def test_a_claimed_domain_is_never_handed_to_another_run(tmp_path: Path) -> None:
    """Two runs that pick at the same time never share a domain (they would see each other's
    nodes); a released id is free again."""
    claimed = [claim_domain_id(tmp_path) for _ in range(FIRST_ID, LAST_ID + 1)]
    try:
        assert sorted(claimed) == list(range(FIRST_ID, LAST_ID + 1))  # each id once
        with pytest.raises(NoFreeDomainError, match="held by other test runs"):
            claim_domain_id(tmp_path)
        release_domain_id(claimed[0])
        assert claim_domain_id(tmp_path) == claimed[0]
    finally:
        for domain in claimed:
            release_domain_id(domain)


def test_a_domain_held_by_another_process_is_skipped(tmp_path: Path) -> None:
    """The claim is the kernel's lock on a file: another process's claim counts too."""
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import sys, time; from pathlib import Path; "
         "from robot_stack_testing.domains import claim_domain_id; "
         "import random; d = claim_domain_id(Path(sys.argv[1]), random.Random(1)); "
         "print(d, flush=True); time.sleep(60)", str(tmp_path)],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout is not None
        theirs = int(holder.stdout.readline())
        ours = [claim_domain_id(tmp_path, random.Random(1)) for _ in range(3)]
        assert theirs not in ours
        for domain in ours:
            release_domain_id(domain)
    finally:
        holder.kill()
        holder.communicate(timeout=10)  # reaped, its pipe closed


def test_wait_until_returns_the_first_truthy_value() -> None:
    values = iter([0, None, "ready"])
    assert wait_until(lambda: next(values), 1.0, interval_s=0.001) == "ready"


def test_wait_until_raises_at_its_deadline_naming_what_it_waited_for() -> None:
    with pytest.raises(TimeoutError, match="the moon"):
        wait_until(lambda: False, 0.05, "the moon", interval_s=0.01)


async def test_async_wait_until_accepts_sync_and_async_predicates() -> None:
    ticks = iter([False, True])
    assert await async_wait_until(lambda: next(ticks), 1.0, interval_s=0.001) is True

    async def ready() -> str:
        await asyncio.sleep(0)
        return "yes"

    assert await async_wait_until(ready, 1.0) == "yes"
    with pytest.raises(TimeoutError, match="never"):
        await async_wait_until(lambda: 0, 0.05, "never", interval_s=0.01)


def test_free_port_is_bindable_and_wait_for_port_sees_a_listener() -> None:
    port = free_tcp_port()
    with socket.socket() as server:
        server.bind(("127.0.0.1", port))
        server.listen()
        wait_for_tcp_port(port, 2.0)
    with pytest.raises(TimeoutError):
        wait_for_tcp_port(port, 0.1)


def test_launcher_captures_output_and_stops_a_process_that_ignores_sigint(tmp_path: Path) -> None:
    launcher = ProcessLauncher(tmp_path)
    stubborn = (
        "import signal, sys, time\n"
        "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
        "print('up', flush=True)\n"
        "time.sleep(60)\n"
    )
    process = launcher.start("stubborn", [sys.executable, "-c", stubborn], env={"X": "1"})
    wait_until(lambda: "up" in process.log(), 10.0, "the child to start")
    assert process.running()
    started = time.monotonic()
    returncode = launcher.stop(process, timeout_s=0.5)
    assert returncode != 0
    assert not process.running()
    assert time.monotonic() - started < 30


def test_stop_all_stops_every_started_process(tmp_path: Path) -> None:
    launcher = ProcessLauncher(tmp_path)
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    processes = [launcher.start(f"sleeper{i}", sleeper) for i in range(2)]
    launcher.stop_all()
    assert not any(process.running() for process in processes)


def test_launcher_fixture_yields_a_working_launcher(launcher: ProcessLauncher) -> None:
    done = launcher.start("echo", [sys.executable, "-c", "print('hello')"])
    wait_until(lambda: not done.running(), 10.0, "echo to exit")
    assert "hello" in done.log()


def test_tcp_port_fixture_is_a_loopback_port(tcp_port: int) -> None:
    assert 0 < tcp_port < 65536
