"""GraphWatcher: what a motion server can see of an intruder on its ROS domain, without SROS2.

Every process that joins the robot's ROS domain can publish on any topic and send goals to any
action server: only DDS Security (SROS2 enclaves with a permissions file per unit) or network
isolation (separate domains, ``ROS_AUTOMATIC_DISCOVERY_RANGE``, a host firewall) closes that.
What the ROS graph does tell (Fast DDS lists every endpoint with its node) is watched here, every
``period_s`` (0.2 s: an alarm within 1 s), from a timer on the bridge's executor:

- **publishers** on a topic beyond those expected (``watch_publishers``): on a motion server's
  own lock topic anyone but this node (twist_mux keeps the last message of any publisher, so a
  second one can open the wheels); on ``/amcl_pose`` or ``/map`` more than one (a fake pose, a
  fake map). The endpoints are matched by node; an intruder that names its node like ours still
  shows as one publisher too many.
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
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import structlog
from action_msgs.msg import GoalStatus, GoalStatusArray
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_ros_bridge.bridge import RosBridge

logger = structlog.get_logger(__name__)

WATCH_PERIOD_S = 0.2
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
    """Publishers tolerated besides this node's own (0 on a lock topic, 1 on /amcl_pose)."""
    own: int
    """This node's own publishers on the topic (1 on its lock topic)."""
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


def foreign_nodes(
    infos: Iterable[Any], own_node: str, own: int, allowed: Iterable[str] = ()
) -> list[str]:
    """The endpoints' nodes beyond ``own`` endpoints of ``own_node`` and the ``allowed`` node
    names (fully qualified, or a bare name in any namespace); one entry per endpoint."""
    allowed_names = set(allowed)
    left = own
    foreign = []
    for info in infos:
        node = _node_of(info)
        if node == own_node and left > 0:
            left -= 1
            continue
        if node in allowed_names or str(info.node_name) in allowed_names:
            continue
        foreign.append(node)
    return foreign


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
        self.looks = 0
        logger.info("ros_graph_watch_started", node=self.own_node, period_s=period_s)

    # -- rules -------------------------------------------------------------------------------
    def watch_publishers(
        self, topic: str, code: str, *, others_allowed: int = 0, own: int = 0, what: str = ""
    ) -> None:
        """Alarm ``code`` while ``topic`` has more publishers than ``own`` of this node's and
        ``others_allowed`` of other nodes."""
        rule = PublisherRule(topic, code, others_allowed, own, what or topic)
        with self._mutex:
            self._publishers.append(rule)

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
            foreign = foreign_nodes(infos, self.own_node, rule.own)
            if len(foreign) > rule.others_allowed:
                self._raise(rule.code, _publisher_detail(rule, foreign))
        for goal in goals:
            if not goal.stopped():
                continue
            infos = node.get_subscriptions_info_by_topic(f"{goal.action}/_action/feedback")
            clients = foreign_nodes(infos, self.own_node, 1, goal.allowed_clients)
            if clients:
                self._raise(
                    goal.code,
                    f"another program ({_names(clients)}) is connected to send {goal.what} "
                    "goals while the robot is stopped; this server locked the robot",
                )
        self.looks += 1

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
    count = len(foreign) + rule.own
    return (
        f"{count} programs publish {rule.what} on {rule.topic} (including {_names(foreign)}), "
        f"where {'only this server' if rule.own else 'only one'} should; this server locked "
        "the robot and refuses motion"
    )
