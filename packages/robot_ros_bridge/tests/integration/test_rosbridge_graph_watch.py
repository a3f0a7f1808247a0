"""GraphWatcher and ActionCanceller over real rclpy (issue 35): a second publisher on a lock
topic or on a pose topic, a goal not ours while stopped, and the action protocol's cancel-all,
which ends every goal of an rclpy ActionServer, whoever sent it."""

import threading
import time
import uuid
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import pytest
from nav2_msgs.action import NavigateToPose
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from std_msgs.msg import Bool

from robot_ros_bridge import RosBridge
from robot_ros_bridge.action_cancel import ActionCanceller
from robot_ros_bridge.graph_watch import MESSAGE_INFO, GraphWatcher, foreign_nodes
from robot_ros_bridge.lock_publisher import LOCK_QOS, SupervisorLockPublisher
from robot_stack_testing import async_wait_until, wait_until

pytestmark = pytest.mark.ros


def _name(prefix: str) -> str:
    return f"/{prefix}_{uuid.uuid4().hex[:8]}"


class Alarms:
    def __init__(self) -> None:
        self.raised: dict[str, str] = {}
        self._mutex = threading.Lock()

    def __call__(self, code: str, detail: str) -> None:
        with self._mutex:
            self.raised[code] = detail

    def codes(self) -> set[str]:
        with self._mutex:
            return set(self.raised)


def spoofed(publisher: Any, value: bool, alarms: Alarms) -> bool:
    """Publish once more (until matched, a message may find no reader); the alarm yet?"""
    publisher.publish(Bool(data=value))
    return "LOCK_TOPIC_SHARED" in alarms.codes()


@pytest.fixture
def bridges() -> Iterator[tuple[RosBridge, RosBridge]]:
    with RosBridge("motion_server") as server, RosBridge("intruder") as intruder:
        yield server, intruder


def test_foreign_nodes_leaves_out_our_own_endpoints_and_the_allowed_ones() -> None:
    def info(ns: str, name: str) -> Any:
        return SimpleNamespace(node_namespace=ns, node_name=name)

    infos = [info("/", "nav"), info("/", "nav"), info("/", "wf"), info("/robot", "x")]

    assert foreign_nodes(infos, "/nav") == ["/robot/x", "/wf"]  # a namesake (ghost) is ours
    assert foreign_nodes(infos, "/nav", allowed=["wf"]) == ["/robot/x"]


def test_a_second_publisher_on_our_lock_topic_is_alarmed_naming_its_node(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, intruder = bridges
    topic = _name("lock")
    alarms = Alarms()
    SupervisorLockPublisher(server, lambda: True, topic=topic)
    watcher = GraphWatcher(server, alarms, period_s=0.05)
    watcher.watch_publishers(topic, "LOCK_TOPIC_SHARED", own=True, what="the lock")
    wait_until(lambda: watcher.looks >= 5, 10, "five looks")
    assert alarms.codes() == set()  # our own publisher alone is no alarm

    spoof = intruder.create_publisher(Bool, topic, LOCK_QOS)
    spoof.publish(Bool(data=False))

    wait_until(lambda: "LOCK_TOPIC_SHARED" in alarms.codes(), 10, "the alarm")
    assert "/intruder" in alarms.raised["LOCK_TOPIC_SHARED"]
    assert topic in alarms.raised["LOCK_TOPIC_SHARED"]
    watcher.close()


def test_a_second_publisher_of_a_pose_is_alarmed_one_is_expected(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, intruder = bridges
    topic = _name("amcl_pose")
    alarms = Alarms()
    watcher = GraphWatcher(server, alarms, period_s=0.05)
    watcher.watch_publishers(topic, "POSE_TOPIC_SHARED", others_allowed=1)
    with RosBridge("base") as base:
        base.create_publisher(Bool, topic)
        wait_until(lambda: watcher.looks >= 5, 10, "five looks")
        assert alarms.codes() == set()
        intruder.create_publisher(Bool, topic)
        wait_until(lambda: "POSE_TOPIC_SHARED" in alarms.codes(), 10, "the alarm")
    watcher.close()


def test_an_open_lock_message_while_we_hold_it_locked_is_alarmed_whatever_its_node_is_named(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, _ = bridges
    topic = _name("lock")
    alarms = Alarms()
    lock = SupervisorLockPublisher(server, lambda: True, topic=topic)
    watcher = GraphWatcher(server, alarms, period_s=0.05)
    watcher.watch_publishers(topic, "LOCK_TOPIC_SHARED", own=True)
    watcher.watch_lock(
        topic, "LOCK_TOPIC_SHARED", locked=lambda: True, last_open_at=lock.last_open_at
    )
    with RosBridge("motion_server") as namesake:  # the graph cannot tell it from us
        spoof = namesake.create_publisher(Bool, topic, LOCK_QOS)
        wait_until(lambda: watcher.looks >= 5, 10, "five looks")
        assert alarms.codes() == set(), alarms.raised
        wait_until(lambda: spoofed(spoof, False, alarms), 10, "the alarm")
    assert "another program publishes" in alarms.raised["LOCK_TOPIC_SHARED"]
    watcher.close()


@pytest.mark.skipif(not MESSAGE_INFO, reason="this rclpy gives no publisher gid (Humble)")
def test_any_message_from_outside_this_process_on_our_lock_is_alarmed_at_once(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    """Even a 'locked' message, from a publisher named like us, while our lock is open too."""
    server, _ = bridges
    topic = _name("lock")
    alarms = Alarms()
    lock = SupervisorLockPublisher(server, lambda: False, topic=topic)
    watcher = GraphWatcher(server, alarms, period_s=60.0)  # no graph look: the message alone
    watcher.watch_lock(
        topic, "LOCK_TOPIC_SHARED", locked=lambda: False, last_open_at=lock.last_open_at
    )
    assert lock.publish() is False
    with RosBridge("motion_server") as namesake:
        spoof = namesake.create_publisher(Bool, topic, LOCK_QOS)
        wait_until(lambda: spoof.get_subscription_count() > 0, 10, "matched")
        assert alarms.codes() == set()  # our own messages meanwhile: no alarm
        wait_until(lambda: spoofed(spoof, True, alarms), 10, "the alarm")
    assert "not this server's" in alarms.raised["LOCK_TOPIC_SHARED"]
    watcher.close()


@pytest.mark.skipif(not MESSAGE_INFO, reason="this rclpy gives no publisher gid (Humble)")
def test_our_own_open_message_delivered_late_is_no_alarm(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    """On a loaded host our own last 'open' can arrive after the lock has locked again and
    after the grace: its gid says it is ours, so it is no intruder (a false alarm latched the
    brain's stop under load, issue 39)."""
    server, _ = bridges
    topic = _name("lock")
    alarms = Alarms()
    lock = SupervisorLockPublisher(server, lambda: False, topic=topic)
    heard = threading.Event()
    server.create_subscription(Bool, topic, lambda msg: heard.set(), LOCK_QOS)
    watcher = GraphWatcher(server, alarms, period_s=60.0)
    watcher.watch_lock(  # held locked, and our last open is long past the grace
        topic, "LOCK_TOPIC_SHARED", locked=lambda: True, last_open_at=lambda: None
    )
    wait_until(lambda: lock.publish() is False and heard.is_set(), 10, "our own open heard")
    heard.clear()
    wait_until(lambda: lock.publish() is False and heard.is_set(), 10, "heard again")
    assert alarms.codes() == set(), alarms.raised
    watcher.close()


def serve_until_canceled(bridge: RosBridge, name: str) -> ActionServer:
    """A NavigateToPose server whose goals run until canceled (Nav2's bt_navigator's shape)."""

    def execute(handle: Any) -> Any:
        while not handle.is_cancel_requested:
            time.sleep(0.01)
        handle.canceled()
        return NavigateToPose.Result()

    return ActionServer(
        bridge.node,
        NavigateToPose,
        name,
        execute,
        goal_callback=lambda _goal: GoalResponse.ACCEPT,
        cancel_callback=lambda _handle: CancelResponse.ACCEPT,
        callback_group=ReentrantCallbackGroup(),
    )


async def test_cancel_all_ends_every_goal_whoever_sent_it(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, intruder = bridges
    name = _name("navigate")
    with RosBridge("base", num_threads=6) as base:  # running goals hold threads
        serve_until_canceled(base, name)
        client = intruder.create_action_client(NavigateToPose, name)
        await intruder.wait_for_server(client, 10.0)
        handles = [
            await intruder.await_future(client.send_goal_async(NavigateToPose.Goal()), 10.0)
            for _ in range(2)
        ]
        assert all(h.accepted for h in handles)

        canceling = await ActionCanceller(server, name).cancel_all(10.0)

        results = [await intruder.await_future(h.get_result_async(), 10.0) for h in handles]
    assert canceling == 2
    assert [r.status for r in results] == [5, 5]  # CANCELED


async def test_a_goal_not_ours_while_stopped_is_canceled_at_once_and_alarmed(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, intruder = bridges
    name = _name("navigate")
    alarms = Alarms()
    stopped = {"now": True}
    with RosBridge("base", num_threads=6) as base:  # running goals hold threads
        serve_until_canceled(base, name)
        canceller = ActionCanceller(server, name)
        watcher = GraphWatcher(server, alarms, period_s=0.05, stale_s=0)
        watcher.watch_goals(
            name,
            "FOREIGN_GOAL_CLIENT",
            ours=lambda goal_id: False,
            stopped=lambda: stopped["now"],
            cancel_all_now=canceller.cancel_all_now,
        )
        client = intruder.create_action_client(NavigateToPose, name)
        await intruder.wait_for_server(client, 10.0)
        await async_wait_until(canceller.ready, 10, "the cancel service ready")
        handle = await intruder.await_future(client.send_goal_async(NavigateToPose.Goal()), 10.0)
        result = await intruder.await_future(handle.get_result_async(), 10.0)
        watcher.close()

    assert result.status == 5  # CANCELED by the watcher's cancel-all
    assert "FOREIGN_GOAL_CLIENT" in alarms.codes()


async def test_while_not_stopped_a_goal_not_ours_is_left_alone(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    server, intruder = bridges
    name = _name("navigate")
    alarms = Alarms()
    with RosBridge("base", num_threads=6) as base:  # running goals hold threads
        serve_until_canceled(base, name)
        canceller = ActionCanceller(server, name)
        watcher = GraphWatcher(server, alarms, period_s=0.05, stale_s=0)
        watcher.watch_goals(
            name,
            "FOREIGN_GOAL_CLIENT",
            ours=lambda goal_id: False,
            stopped=lambda: False,
            cancel_all_now=canceller.cancel_all_now,
        )
        client = intruder.create_action_client(NavigateToPose, name)
        await intruder.wait_for_server(client, 10.0)
        handle = await intruder.await_future(client.send_goal_async(NavigateToPose.Goal()), 10.0)
        looks = watcher.looks
        await async_wait_until(lambda: watcher.looks >= looks + 5, 10, "five more looks")
        assert alarms.codes() == set()
        await intruder.await_future(handle.cancel_goal_async(), 10.0)
        watcher.close()


async def test_a_goal_left_running_before_the_watcher_started_is_cancelled_without_alarm(
    bridges: tuple[RosBridge, RosBridge],
) -> None:
    """A restarted server finds its killed predecessor's goal: cancelled, no intrusion."""
    server, intruder = bridges
    name = _name("navigate")
    alarms = Alarms()
    with RosBridge("base", num_threads=6) as base:
        serve_until_canceled(base, name)
        client = intruder.create_action_client(NavigateToPose, name)
        await intruder.wait_for_server(client, 10.0)
        handle = await intruder.await_future(client.send_goal_async(NavigateToPose.Goal()), 10.0)
        canceller = ActionCanceller(server, name)
        watcher = GraphWatcher(server, alarms, period_s=0.05, stale_s=30.0)
        await async_wait_until(canceller.ready, 10, "the cancel service ready")
        watcher.watch_goals(
            name,
            "FOREIGN_GOAL_CLIENT",
            ours=lambda goal_id: False,
            stopped=lambda: True,
            cancel_all_now=canceller.cancel_all_now,
            allowed_clients=["intruder"],  # the predecessor's client is the same node here
        )
        result = await intruder.await_future(handle.get_result_async(), 10.0)
        watcher.close()

    assert result.status == 5  # CANCELED
    assert alarms.codes() == set()
