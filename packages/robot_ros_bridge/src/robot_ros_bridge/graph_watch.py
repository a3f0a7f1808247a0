"""GraphWatcher: what a motion server can see of an intruder on its ROS domain, without SROS2.

Every process that joins the robot's ROS domain can publish on any topic and send goals to any
action server: only DDS Security (SROS2 enclaves with a permissions file per unit) or network
isolation (separate domains, ``ROS_AUTOMATIC_DISCOVERY_RANGE``, a host firewall) closes that.
What the ROS graph does tell (Fast DDS lists every endpoint with its node) is watched here, every
``period_s`` (0.2 s: an alarm within 1 s), from a timer on the bridge's executor:

- **publishers** on a topic beyond those expected (``watch_publishers``): on a motion server's
  own lock topic any node but this one (twist_mux keeps the last message of any publisher, so a
  second one can open the wheels); on ``/amcl_pose`` or ``/map`` more than one node (a fake
  pose, a fake map). Endpoints are told apart by node name (rclpy offers no gid of our own
  publisher), so a restarted server's dead predecessor is not an intruder (``foreign_nodes``);
- **open messages on our lock** while we hold it locked (``watch_lock``): a publisher whatever
  its node is called (one named like ours included).
- **goals** (``watch_goals``): while ``stopped()`` (the server refuses motion: latched, alarmed,
  unsupervised), any goal on the action's status topic that is ACCEPTED or EXECUTING and was not
  sent by this server is cancelled at once (the action's cancel-all) and reported; so is a second
  client of the action (a subscriber of its feedback topic other than this node and the
  ``allowed_clients`` node names, e.g. Nav2's own ``waypoint_follower``).

Each finding calls ``raise_alarm(code, detail)`` (``Supervision.raise_alarm``) again on every
look while it lasts, with a plain-English ``detail`` naming the nodes (never a gid or a secret).
Uses only graph calls rclpy has had since Foxy (``get_publishers_info_by_topic``,
``get_subscriptions_info_by_topic``), so it runs on Humble as on Kilted.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import structlog
from action_msgs.msg import GoalStatus, GoalStatusArray
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_ros_bridge.bridge import RosBridge

logger = structlog.get_logger(__name__)

WATCH_PERIOD_S = 0.2
OWN_OPEN_GRACE_S = 0.5
"""After our own last ``false`` on the lock topic, how long an open message may still be ours."""
ACTIVE = (GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING)
STATUS_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""An action server's status topic (rcl's ``rcl_action_qos_profile_status_default``)."""

RaiseAlarm = Callable[[str, str], object]


@dataclass(frozen=True)
class PublisherRule:
    topic: str
    code: str
    others_allowed: int
    """Other nodes tolerated as publishers (0 on our own lock topic, 1 on /amcl_pose)."""
    own: bool
    """This node publishes the topic itself (its lock topic)."""
    what: str


@dataclass(frozen=True)
class LockRule:
    topic: str
    code: str
    locked: Callable[[], bool]
    last_open_at: Callable[[], float | None]
    what: str


@dataclass(frozen=True)
class GoalRule:
    action: str
    code: str
    ours: Callable[[bytes], bool]
    stopped: Callable[[], bool]
    cancel_all_now: Callable[[], object]
    allowed_clients: frozenset[str]
    what: str


def _node_of(info: Any) -> str:
    namespace = str(info.node_namespace).rstrip("/")
    return f"{namespace}/{info.node_name}"


UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
"""The name rmw gives an endpoint whose participant's node list has not arrived yet (for a few
ms after discovery), or whose writer belongs to no ROS node at all (plain DDS)."""
UNKNOWN_LOOKS = 5
"""Looks in a row (1 s) an unnamed endpoint must persist before it counts as foreign."""


def foreign_nodes(infos: Iterable[Any], own_node: str, allowed: Iterable[str] = ()) -> list[str]:
    """The distinct nodes of the endpoints other than ``own_node`` and the ``allowed`` node
    names (fully qualified, or a bare name in any namespace), sorted.

    Endpoints of a node named like ours count as ours: a motion server restarted after a
    ``kill -9`` still sees its dead predecessor's endpoints until the DDS participant lease
    runs out (20 s by default), and that ghost publishes nothing. An intruder that names its
    node like ours is therefore not told apart by the graph — on the lock topic its messages
    give it away (:meth:`GraphWatcher.watch_lock`); only SROS2 closes the rest."""
    allowed_names = set(allowed)
    foreign = set()
    for info in infos:
        node = _node_of(info)
        if node == own_node or node in allowed_names or str(info.node_name) in allowed_names:
            continue
        foreign.add(node)
    return sorted(foreign)


class GraphWatcher:
    def __init__(
        self, bridge: RosBridge, raise_alarm: RaiseAlarm, *, period_s: float = WATCH_PERIOD_S
    ) -> None:
        if period_s <= 0:
            raise ValueError("period_s must be positive")
        self._bridge = bridge
        self._raise = raise_alarm
        self._publishers: list[PublisherRule] = []
        self._goals: list[GoalRule] = []
        self._mutex = threading.Lock()
        node = bridge.node
        self.own_node = f"{node.get_namespace().rstrip('/')}/{node.get_name()}"
        self._timer: Any = node.create_timer(period_s, self._look)
        self._subscriptions: list[Any] = []
        self._unnamed: dict[str, int] = {}  # looks in a row a topic had unnamed endpoints
        self.looks = 0
        logger.info("ros_graph_watch_started", node=self.own_node, period_s=period_s)

    # -- rules -------------------------------------------------------------------------------
    def watch_publishers(
        self, topic: str, code: str, *, others_allowed: int = 0, own: bool = False, what: str = ""
    ) -> None:
        """Alarm ``code`` while more than ``others_allowed`` nodes besides this one publish
        ``topic``."""
        rule = PublisherRule(topic, code, others_allowed, own, what or topic)
        with self._mutex:
            self._publishers.append(rule)

    def watch_lock(
        self,
        topic: str,
        code: str,
        *,
        locked: Callable[[], bool],
        last_open_at: Callable[[], float | None],
        what: str = "",
    ) -> None:
        """Alarm ``code`` when an *open* (``false``) message arrives on our lock topic while we
        hold it locked and published no open for ``OWN_OPEN_GRACE_S`` (``last_open_at``, the
        lock publisher's monotonic time): another publisher, whatever its node is called."""
        from std_msgs.msg import Bool

        from robot_ros_bridge.lock_publisher import LOCK_QOS

        rule = LockRule(topic, code, locked, last_open_at, what or topic)
        subscription = self._bridge.create_subscription(
            Bool, topic, self._lock_callback(rule), LOCK_QOS
        )
        with self._mutex:
            self._subscriptions.append(subscription)

    def watch_goals(
        self,
        action: str,
        code: str,
        *,
        ours: Callable[[bytes], bool],
        stopped: Callable[[], bool],
        cancel_all_now: Callable[[], object],
        allowed_clients: Iterable[str] = (),
        what: str = "",
    ) -> None:
        """While ``stopped()``: a goal of ``action`` not ``ours`` (its 16-byte goal id) is
        cancelled at once and alarmed, and so is another client of the action."""
        name = action.rstrip("/")
        rule = GoalRule(
            name, code, ours, stopped, cancel_all_now, frozenset(allowed_clients), what or name
        )
        subscription = self._bridge.create_subscription(
            GoalStatusArray, f"{name}/_action/status", self._status_callback(rule), STATUS_QOS
        )
        with self._mutex:
            self._goals.append(rule)
            self._subscriptions.append(subscription)

    # -- looking -----------------------------------------------------------------------------
    def _lock_callback(self, rule: LockRule) -> Callable[[Any], None]:
        def on_lock(msg: Any) -> None:  # executor thread
            if msg.data or not rule.locked():
                return
            opened = rule.last_open_at()
            if opened is not None and time.monotonic() - opened < OWN_OPEN_GRACE_S:
                return  # our own last "open", still on its way
            self._raise(
                rule.code,
                f"another program publishes 'open' on {rule.what} ({rule.topic}) while this "
                "server holds it locked; this server keeps the robot locked and refuses motion",
            )

        return on_lock

    def _status_callback(self, rule: GoalRule) -> Callable[[Any], None]:
        def on_status(msg: Any) -> None:  # executor thread: at once, not at the next look
            if not rule.stopped():
                return
            foreign = [
                s
                for s in msg.status_list
                if s.status in ACTIVE and not rule.ours(bytes(s.goal_info.goal_id.uuid))
            ]
            if not foreign:
                return
            rule.cancel_all_now()
            self._raise(
                rule.code,
                f"a {rule.what} goal this server did not send reached the robot while it is "
                "stopped; it was cancelled, and this server locked the robot",
            )

        return on_status

    def _look(self) -> None:
        """One look at the graph (the timer; also callable directly)."""
        try:
            self.look()
        except Exception:  # a graph query failing must not stop the watch
            logger.exception("ros_graph_watch_failed")

    def look(self) -> None:
        node = self._bridge.node
        with self._mutex:
            publishers, goals = list(self._publishers), list(self._goals)
        for rule in publishers:
            infos = node.get_publishers_info_by_topic(rule.topic)
            foreign = self._settled(rule.topic, foreign_nodes(infos, self.own_node))
            if len(foreign) > rule.others_allowed:
                self._raise(rule.code, _publisher_detail(rule, foreign))
        for goal in goals:
            if not goal.stopped():
                continue
            infos = node.get_subscriptions_info_by_topic(f"{goal.action}/_action/feedback")
            feedback = f"{goal.action}/_action/feedback"
            clients = self._settled(
                feedback, foreign_nodes(infos, self.own_node, goal.allowed_clients)
            )
            if clients:
                self._raise(
                    goal.code,
                    f"another program ({_names(clients)}) is connected to send {goal.what} "
                    "goals while the robot is stopped; this server locked the robot",
                )
        self.looks += 1

    def _settled(self, topic: str, foreign: list[str]) -> list[str]:
        """``foreign`` without endpoints still unnamed, unless they stayed so UNKNOWN_LOOKS."""
        unnamed = [n for n in foreign if n.endswith(UNKNOWN_NODE)]
        if not unnamed:
            self._unnamed.pop(topic, None)
            return foreign
        looks = self._unnamed[topic] = self._unnamed.get(topic, 0) + 1
        if looks >= UNKNOWN_LOOKS:
            return [n for n in foreign if n not in unnamed] + ["an unnamed DDS participant"]
        return [n for n in foreign if n not in unnamed]

    def close(self) -> None:
        """Stop watching (idempotent)."""
        with self._mutex:
            timer, self._timer = self._timer, None
            subscriptions, self._subscriptions = self._subscriptions, []
        if timer is None or self._bridge.closed:
            return
        self._bridge.node.destroy_timer(timer)
        for subscription in subscriptions:
            self._bridge.destroy_subscription(subscription)


def _names(nodes: list[str]) -> str:
    unique = sorted(set(nodes))
    return ", ".join(unique) if unique else "unnamed"


def _publisher_detail(rule: PublisherRule, foreign: list[str]) -> str:
    count = len(foreign) + int(rule.own)
    return (
        f"{count} programs publish {rule.what} on {rule.topic} (including {_names(foreign)}), "
        f"where {'only this server' if rule.own else 'only one'} should; this server locked "
        "the robot and refuses motion"
    )
