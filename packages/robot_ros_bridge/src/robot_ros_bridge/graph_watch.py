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
- **messages on our lock** (``watch_lock``): one from a publisher whose gid is not one of this
  node's (rclpy's MessageInfo, Iron and later: at the first message, before discovery has named
  the sender), or an open (``false``) one while we hold the lock locked (Humble too): a
  publisher whatever its node is called (one named like ours included).
- **goals** (``watch_goals``): while ``stopped()`` (the server refuses motion: latched, alarmed,
  unsupervised), any goal on the action's status topic that is ACCEPTED or EXECUTING and was not
  sent by this server is cancelled at once (the action's cancel-all) and reported — goals
  already running in the first ``stale_s`` (a killed predecessor's) are cancelled silently; so
  is a second client of the action (a subscriber of its feedback topic other than this node and the
  ``allowed_clients`` node names, e.g. Nav2's own ``waypoint_follower``).

Each finding calls ``raise_alarm(code, detail)`` (``Supervision.raise_alarm``) again on every
look while it lasts, with a plain-English ``detail`` naming the nodes (never a gid or a secret).
Uses only graph calls rclpy has had since Foxy (``get_publishers_info_by_topic``,
``get_subscriptions_info_by_topic``), so it runs on Humble as on Kilted.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import structlog
from action_msgs.msg import GoalStatus, GoalStatusArray
from rclpy import subscription as rclpy_subscription
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool

from robot_ros_bridge.bridge import RosBridge

logger = structlog.get_logger(__name__)

WATCH_PERIOD_S = 0.2
STALE_GOALS_S = 3.0
"""Goals already running when the watcher starts (within this long: the action's latched
status arrives on discovery) are a killed predecessor's: cancelled while stopped, no alarm."""
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
MESSAGE_INFO = hasattr(rclpy_subscription, "MessageInfo")
"""This rclpy hands a two-argument callback the MessageInfo with the publisher's gid."""


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
UNKNOWN_GRACE_S = 1.0
"""How long an unnamed endpoint must persist (looks in a row) before it counts as foreign."""


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
        self,
        bridge: RosBridge,
        raise_alarm: RaiseAlarm,
        *,
        period_s: float = WATCH_PERIOD_S,
        stale_s: float = STALE_GOALS_S,
    ) -> None:
        if period_s <= 0 or stale_s < 0:
            raise ValueError("period_s must be positive, stale_s >= 0")
        self._started = time.monotonic()
        self._stale_s = stale_s
        self._stale: set[bytes] = set()  # goals running before we looked: a predecessor's
        self._bridge = bridge
        self._raise = raise_alarm
        self._publishers: list[PublisherRule] = []
        self._goals: list[GoalRule] = []
        self._mutex = threading.Lock()
        node = bridge.node
        self.own_node = f"{node.get_namespace().rstrip('/')}/{node.get_name()}"
        self._timer: Any = node.create_timer(period_s, self._look)
        self._subscriptions: list[Any] = []
        self._unnamed: dict[str, float] = {}  # since when a topic has had unnamed endpoints
        self._last_status: dict[str, tuple[GoalRule, Any]] = {}
        self._prefix: bytes | None = None
        # a publisher on a topic of our own: its gid names our DDS participant (its prefix)
        self._marker_topic = f"/_robot_stack/graph_watch_{uuid.uuid4().hex[:12]}"
        self._marker: Any = bridge.create_publisher(Bool, self._marker_topic, 1)
        self._callbacks: dict[str, Callable[[Any], None]] = {}
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
        """Alarm ``code`` when a message on our lock topic comes from a publisher outside this
        process (its gid, where rclpy gives it), or an *open* (``false``) one arrives while we
        hold the lock locked and published no open for ``OWN_OPEN_GRACE_S`` (``last_open_at``,
        the lock publisher's monotonic time): another publisher, whatever its node is called."""
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
        callback = self._status_callback(rule)
        subscription = self._bridge.create_subscription(
            GoalStatusArray, f"{name}/_action/status", callback, STATUS_QOS
        )
        with self._mutex:
            self._callbacks[name] = callback
            self._goals.append(rule)
            self._subscriptions.append(subscription)

    # -- looking -----------------------------------------------------------------------------
    def _lock_callback(self, rule: LockRule) -> Callable[..., None]:
        def on_lock(msg: Any, info: Any = None) -> None:  # executor thread
            gid = _publisher_gid(info)
            own = self._own_gid(rule.topic, gid) if gid is not None else None
            if own is not None:  # the sender is known: only a foreign one is an intruder
                if not own:
                    self._raise(
                        rule.code,
                        f"another program publishes on {rule.what} ({rule.topic}): a message "
                        "came from a publisher that is not this server's; this server locked "
                        "the robot and refuses motion",
                    )
                # our own "open", however late a loaded host delivers it, is no intruder
                return
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

        if not MESSAGE_INFO:  # Humble: no publisher gid with the message, the value check only

            def on_lock_humble(msg: Any) -> None:
                on_lock(msg)

            return on_lock_humble

        def on_lock_with_info(msg: Any, info: Any) -> None:
            on_lock(msg, info)

        return on_lock_with_info

    def _own_gid(self, topic: str, gid: bytes) -> bool | None:
        """``gid`` is one of this process's publishers: its DDS participant's GUID prefix (the
        gid's first 12 bytes) is ours — a dead predecessor's or a namesake's differs. None: not
        known yet (right after start our own endpoints may not be in the graph yet, and our
        own first messages must not count as an intruder's)."""
        prefix = self._own_prefix()
        if prefix is not None:
            return gid[:12] == prefix
        infos = self._bridge.node.get_publishers_info_by_topic(topic)  # no prefix: by name
        ours = [bytes(i.endpoint_gid)[:16] for i in infos if _node_of(i) == self.own_node]
        if not ours:
            return None
        return gid in ours

    def _own_prefix(self) -> bytes | None:
        with self._mutex:
            if self._prefix is not None:
                return self._prefix
        infos = self._bridge.node.get_publishers_info_by_topic(self._marker_topic)
        gids = [bytes(i.endpoint_gid) for i in infos if _node_of(i) == self.own_node]
        if len(gids) != 1 or len(gids[0]) < 12:
            return None
        with self._mutex:
            self._prefix = gids[0][:12]
        return gids[0][:12]

    def _status_callback(self, rule: GoalRule) -> Callable[[Any], None]:
        def on_status(msg: Any) -> None:  # executor thread: at once, not at the next look
            with self._mutex:
                self._last_status[rule.action] = (rule, msg)  # looked at again each look
            if not rule.stopped():
                return
            foreign = {
                bytes(s.goal_info.goal_id.uuid)
                for s in msg.status_list
                if s.status in ACTIVE and not rule.ours(bytes(s.goal_info.goal_id.uuid))
            }
            if not foreign:
                return
            rule.cancel_all_now()
            with self._mutex:
                if time.monotonic() - self._started < self._stale_s:
                    self._stale |= foreign
                fresh = foreign - self._stale
            if not fresh:  # left by a killed predecessor: cancelled, no intrusion
                logger.warning("stale_goals_canceled", action=rule.action, goals=len(foreign))
                return
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
        with self._mutex:
            statuses = [(self._callbacks[a], m) for a, (_, m) in self._last_status.items()]
        for callback, msg in statuses:  # a goal still running (a cancel lost or refused)
            callback(msg)
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
        """``foreign`` without endpoints still unnamed, unless they stayed so UNKNOWN_GRACE_S."""
        unnamed = [n for n in foreign if n.endswith(UNKNOWN_NODE)]
        if not unnamed:
            self._unnamed.pop(topic, None)
            return foreign
        since = self._unnamed.setdefault(topic, time.monotonic())
        if time.monotonic() - since >= UNKNOWN_GRACE_S:
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
        self._bridge.node.destroy_publisher(self._marker)
        for subscription in subscriptions:
            self._bridge.destroy_subscription(subscription)


def _publisher_gid(info: Any) -> bytes | None:
    """The sending publisher's gid from an rclpy MessageInfo (Iron and later), else None."""
    if not isinstance(info, dict):
        return None
    gid = info.get("publisher_gid")
    data = gid.get("data") if isinstance(gid, dict) else None
    return bytes(data)[:16] if data is not None else None


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
