"""One rclpy Context + Node + MultiThreadedExecutor spinning in a daemon thread, and the
asyncio side of it (ARCHITECTURE.md §3).

Service futures are handed to the event loop with ``call_soon_threadsafe`` and awaited under
``asyncio.timeout`` (not ``wait_for``, which on 3.11 can swallow a cancel); a timed-out
request is removed from the client's pending table. A service nobody serves is a fast, clean
:class:`ServiceUnavailableError`, never a hang.

First call after discovery: ``service_is_ready()`` only says that *this* side has matched
the server (request writer and reply reader). The server matches our reply reader on its
own, asynchronously; if our request reaches it first, rmw_fastrtps waits the reply writer's
``max_blocking_time`` (100 ms) and then drops the reply ("failed to send response (timeout):
client will not receive response"), and the call can only time out. Under CPU load that gap
exceeds 100 ms. So a service must have been ready for ``discovery_settle_s`` before a request
is sent (:class:`ReadinessTracker`); the bridge observes every client it created on a timer,
so only a call made right after the server appeared waits. Requests are never retried (a
create must not run twice).
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import Any, Literal, TypeVar

import rclpy
import structlog
from rclpy.action.client import ActionClient
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.exceptions import InvalidHandle
from rclpy.executors import (
    Executor,
    ExternalShutdownException,
    MultiThreadedExecutor,
    SingleThreadedExecutor,
)
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from robot_ros_bridge.errors import BridgeClosedError, ServiceTimeoutError, ServiceUnavailableError
from robot_ros_bridge.spinning import drain_callbacks, spin_until_shutdown

logger = structlog.get_logger(__name__)

T = TypeVar("T")
_SERVICE_POLL_S = 0.05
DEFAULT_DISCOVERY_SETTLE_S = 1.0
"""How long a service must have been continuously ready before the first request."""


def _contained(callback: Callable[..., Any], where: str) -> Callable[..., Any]:
    """``callback`` with its exceptions logged instead of raised into the executor.

    An exception that reaches ``executor.spin()`` unwinds the spin with other work of that
    turn in flight (a service reply being delivered can be lost, and its call times out), so
    a callback's failure stays inside the callback. Keeps the arity: rclpy passes the
    ``MessageInfo`` only to two-argument subscription callbacks.
    """
    if _accepts_two(callback):

        def two(first: Any, second: Any) -> Any:
            try:
                return callback(first, second)
            except Exception:  # a ROS callback is a boundary: log it, keep spinning
                logger.exception("ros_callback_failed", where=where)
                return second  # a service handler's response object: answered as is

        return two

    def one(msg: Any) -> Any:
        try:
            return callback(msg)
        except Exception:  # a ROS callback is a boundary: log it, keep spinning
            logger.exception("ros_callback_failed", where=where)
            return None

    return one


def _is_ready(client: Any) -> bool:
    """A service client's or an action client's server is matched (both sides' entities)."""
    if isinstance(client, ActionClient):
        return bool(client.server_is_ready())
    return bool(client.service_is_ready())


def _accepts_two(callback: Callable[..., Any]) -> bool:
    try:
        inspect.signature(callback).bind(object(), object())
    except TypeError:
        return False
    return True


class ReadinessTracker:
    """Per client: since when its service has been continuously ready (pure, thread-safe).

    ``observe(client, ready, now)`` records one observation and returns the time the service
    became ready (``None`` when it is not ready); a not-ready observation resets it.
    """

    def __init__(self, settle_s: float) -> None:
        if settle_s < 0:
            raise ValueError("settle_s must be >= 0")
        self.settle_s = settle_s
        self._since: weakref.WeakKeyDictionary[Any, float] = weakref.WeakKeyDictionary()
        self._lock = threading.Lock()

    def observe(self, client: Any, ready: bool, now: float) -> float | None:
        with self._lock:
            if not ready:
                self._since.pop(client, None)
                return None
            return self._since.setdefault(client, now)

    def settled_at(self, client: Any, ready: bool, now: float) -> float | None:
        """When the service counts as settled (``<= now``: send), or ``None`` if not ready."""
        since = self.observe(client, ready, now)
        return None if since is None else since + self.settle_s


class RosBridge:
    """Owns the ROS side of one process. Thread-safe; create once in the composition root.

    Use as a context manager or call :meth:`start` / :meth:`close`.

    ``executor="single_threaded"`` spins a ``SingleThreadedExecutor`` instead: callbacks run one
    at a time, at a fraction of the CPU per message (measured: 50 raw messages/s cost ~1 % of
    a core single-threaded against ~6 % with the multi-threaded executor). For a process whose
    callbacks are short and never wait on each other (a recorder), not for one whose service
    handlers block.
    """

    def __init__(
        self,
        node_name: str,
        *,
        namespace: str = "",
        num_threads: int = 2,
        args: Sequence[str] | None = None,
        discovery_settle_s: float = DEFAULT_DISCOVERY_SETTLE_S,
        executor: Literal["multi_threaded", "single_threaded"] = "multi_threaded",
    ) -> None:
        if executor not in ("multi_threaded", "single_threaded"):
            raise ValueError(
                f"executor must be multi_threaded or single_threaded, not {executor!r}"
            )
        self._executor_kind = executor
        self._node_name = node_name
        self._namespace = namespace
        self._num_threads = num_threads
        self._args = list(args) if args is not None else []
        self._context: Context | None = None
        self._node: Node | None = None
        self._executor: Executor | None = None
        self._thread: threading.Thread | None = None
        self._group = ReentrantCallbackGroup()
        self._closed = False
        self._readiness = ReadinessTracker(discovery_settle_s)
        self._watched: weakref.WeakSet[Any] = weakref.WeakSet()
        self._watch_timer: Any = None

    # -- lifecycle -----------------------------------------------------------------------
    def start(self) -> RosBridge:
        if self._closed:
            raise BridgeClosedError("the ROS bridge was closed and cannot be restarted")
        if self._context is not None:
            return self
        context = Context()
        rclpy.init(context=context, args=self._args)
        node = Node(self._node_name, namespace=self._namespace, context=context)
        executor: Executor = (
            SingleThreadedExecutor(context=context)
            if self._executor_kind == "single_threaded"
            else MultiThreadedExecutor(num_threads=self._num_threads, context=context)
        )
        executor.add_node(node)
        self._context, self._node, self._executor = context, node, executor
        self._thread = threading.Thread(
            target=self._spin, name=f"ros-spin-{self._node_name}", daemon=True
        )
        self._thread.start()
        logger.info("ros_bridge_started", node=node.get_fully_qualified_name())
        return self

    def _spin(self) -> None:
        """Spin until shutdown. A callback that raises is logged and spinning goes on: one
        bad callback must not take the whole ROS side of the process down."""
        executor, context = self._executor, self._context
        assert executor is not None
        assert context is not None
        with contextlib.suppress(ExternalShutdownException):
            spin_until_shutdown(executor, lambda: not self._closed and context.ok(), turn_s=0.5)

    def close(self, timeout_s: float = 5.0) -> None:
        """End the spin thread, then shut the executor down, destroy the node and shut the
        context down, in that order (see ``spinning``). Idempotent."""
        if self._closed:
            return
        self._closed = True
        executor, node, context, thread = self._executor, self._node, self._context, self._thread
        if executor is not None:
            executor.wake()
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=timeout_s)
            if thread.is_alive():
                logger.warning("ros_bridge_spin_still_running", timeout_s=timeout_s)
        if executor is not None:
            drain_callbacks(executor, timeout_s)
            executor.shutdown(timeout_sec=timeout_s)
        self._watch_timer = None  # destroyed with the node, after callbacks in flight end
        if node is not None:
            node.destroy_node()
        if context is not None:
            context.try_shutdown()
        logger.info("ros_bridge_closed", node=self._node_name)

    def __enter__(self) -> RosBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def node(self) -> Node:
        if self._closed:
            raise BridgeClosedError("the ROS bridge is closed")
        if self._node is None:
            raise BridgeClosedError("the ROS bridge was not started")
        return self._node

    # -- entities ------------------------------------------------------------------------
    def create_client(self, srv_type: Any, service_name: str) -> Any:
        """A service client in the bridge's reentrant callback group; its service's readiness
        is observed in the background so the first call does not wait to settle."""
        client: Any = self.node.create_client(srv_type, service_name, callback_group=self._group)
        self._watched.add(client)
        self._ensure_watch_timer()
        return client

    def create_action_client(self, action_type: Any, action_name: str) -> Any:
        """An action client in the bridge's reentrant callback group; like a service client,
        its server's readiness is observed in the background (see :meth:`wait_for_server`)."""
        client: Any = ActionClient(self.node, action_type, action_name, callback_group=self._group)
        self._watched.add(client)
        self._ensure_watch_timer()
        return client

    def _ensure_watch_timer(self) -> None:
        if self._watch_timer is None:
            self._watch_timer = self.node.create_timer(
                _SERVICE_POLL_S, self._observe_clients, callback_group=self._group
            )

    async def wait_for_server(self, client: Any, timeout_s: float) -> None:
        """Return once ``client``'s server (service or action) is ready and has settled
        (``discovery_settle_s``, at most half of ``timeout_s``), else raise
        :class:`ServiceUnavailableError` after ``timeout_s``. Never sends anything."""
        if self._closed or self._node is None:
            raise BridgeClosedError("the ROS bridge is closed")
        started = time.monotonic()
        while True:
            now = time.monotonic()
            settled_at = self._readiness.settled_at(client, _is_ready(client), now)
            if settled_at is not None and now >= min(settled_at, started + timeout_s / 2):
                return
            if settled_at is None and now >= started + timeout_s:
                name = getattr(client, "service_name", None) or getattr(client, "_action_name", "")
                raise ServiceUnavailableError(
                    f"no server for {name} (is it running in this ROS domain?)"
                )
            await asyncio.sleep(_SERVICE_POLL_S)

    async def await_future(self, ros_future: Any, timeout_s: float | None) -> Any:
        """The result of an rclpy future (completed on the executor thread), awaited on the
        event loop under ``asyncio.timeout``; :class:`ServiceTimeoutError` after
        ``timeout_s`` (``None``: no deadline, the caller sets one). The rclpy future itself
        is left alone (the caller decides)."""
        loop = asyncio.get_running_loop()
        answer: asyncio.Future[Any] = loop.create_future()

        def _deliver(done: Any) -> None:
            def _set() -> None:
                if answer.done():
                    return
                exc = done.exception()
                if exc is not None:
                    answer.set_exception(exc)
                else:
                    answer.set_result(done.result())

            if not loop.is_closed():
                loop.call_soon_threadsafe(_set)

        ros_future.add_done_callback(_deliver)
        try:
            async with asyncio.timeout(timeout_s):
                return await answer
        except TimeoutError:
            raise ServiceTimeoutError(f"no answer within {timeout_s} s") from None

    def _observe_clients(self) -> None:
        if self._closed:
            return
        now = time.monotonic()
        for client in list(self._watched):
            try:
                ready = _is_ready(client)
            except InvalidHandle:  # destroyed while closing
                continue
            self._readiness.observe(client, ready, now)

    def create_service(
        self, srv_type: Any, service_name: str, handler: Callable[[Any, Any], Any]
    ) -> Any:
        """A service server whose handler may run concurrently with other callbacks."""
        return self.node.create_service(
            srv_type, service_name, _contained(handler, service_name), callback_group=self._group
        )

    def create_subscription(
        self,
        msg_type: Any,
        topic: str,
        callback: Callable[[Any], None] | Callable[[Any, Any], None],
        qos: QoSProfile | int = 10,
        *,
        raw: bool = False,
    ) -> Any:
        """A subscription whose callback runs on an executor thread (keep it short); a
        two-argument callback also gets the rclpy ``MessageInfo`` (publisher GID, ...).
        ``raw=True`` hands the callback the serialized (CDR) bytes, undecoded."""
        return self.node.create_subscription(
            msg_type, topic, _contained(callback, topic), qos, callback_group=self._group, raw=raw
        )

    def destroy_subscription(self, subscription: Any) -> None:
        if not self._closed and self._node is not None:
            self._node.destroy_subscription(subscription)

    def create_publisher(self, msg_type: Any, topic: str, qos: QoSProfile | int = 10) -> Any:
        return self.node.create_publisher(msg_type, topic, qos)

    # -- graph ---------------------------------------------------------------------------
    def offered_qos(self, topic: str, depth: int = 10) -> QoSProfile:
        """The strongest QoS every current publisher of ``topic`` offers: reliable and
        transient-local when all offer it (a late subscriber then still gets the latched
        last message of a publisher that is about to leave), else best effort / volatile,
        which matches any publisher."""
        profiles = [info.qos_profile for info in self.node.get_publishers_info_by_topic(topic)]
        reliable = bool(profiles) and all(
            p.reliability == ReliabilityPolicy.RELIABLE for p in profiles
        )
        latched = bool(profiles) and all(
            p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in profiles
        )
        return QoSProfile(
            depth=depth,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        )

    def topic_names_and_types(self) -> dict[str, list[str]]:
        """Every topic in the graph with its type names (e.g. ``pkg/msg/Type``)."""
        return {name: list(types) for name, types in self.node.get_topic_names_and_types()}

    def service_names_and_types(self) -> dict[str, list[str]]:
        return {name: list(types) for name, types in self.node.get_service_names_and_types()}

    def publisher_count(self, topic: str) -> int:
        count: int = self.node.count_publishers(topic)
        return count

    # -- calls ---------------------------------------------------------------------------
    async def call_service(
        self,
        client: Any,
        request: Any,
        timeout_s: float,
        *,
        wait_for_service_s: float = 0.0,
    ) -> Any:
        """Call ``client`` with ``request`` and return the response.

        ``wait_for_service_s`` (bounded by ``timeout_s``) tolerates a server that is still
        being discovered; after it, a missing server raises :class:`ServiceUnavailableError`.
        A server that appeared less than ``discovery_settle_s`` ago is given the rest of that
        time (at most half of ``timeout_s``) to match our reply reader before the request is
        sent.
        No answer within ``timeout_s`` (measured from the call) raises
        :class:`ServiceTimeoutError` and drops the pending request.
        """
        if self._closed or self._node is None:
            raise BridgeClosedError("the ROS bridge is closed")
        service = client.service_name
        started = time.monotonic()
        deadline = started + timeout_s
        wait_deadline = started + min(wait_for_service_s, timeout_s)
        while True:
            now = time.monotonic()
            settled_at = self._readiness.settled_at(client, bool(client.service_is_ready()), now)
            if settled_at is None:
                if now >= wait_deadline:
                    raise ServiceUnavailableError(
                        f"no server for {service} (is the node running in this ROS domain?)"
                    )
            elif now >= min(settled_at, started + timeout_s / 2):
                break  # settled, or half the call's time is spent: send (never retried)
            await asyncio.sleep(_SERVICE_POLL_S)

        loop = asyncio.get_running_loop()
        answer: asyncio.Future[Any] = loop.create_future()

        def _deliver(ros_future: Any) -> None:
            def _set() -> None:
                if answer.done():
                    return
                exc = ros_future.exception()
                if exc is not None:
                    answer.set_exception(exc)
                else:
                    answer.set_result(ros_future.result())

            if not loop.is_closed():
                loop.call_soon_threadsafe(_set)

        ros_future = client.call_async(request)
        ros_future.add_done_callback(_deliver)
        remaining = max(deadline - time.monotonic(), 0.0)
        try:
            # asyncio.timeout, not wait_for: on 3.11 wait_for swallows a cancel that lands as
            # the answer arrives, and a polling loop then never ends.
            async with asyncio.timeout(remaining):
                response = await answer
        except TimeoutError:
            client.remove_pending_request(ros_future)
            raise ServiceTimeoutError(
                f"{service} did not answer within {timeout_s:.1f} s"
            ) from None
        except asyncio.CancelledError:
            client.remove_pending_request(ros_future)
            raise
        logger.debug(
            "ros_service_call",
            service=service,
            duration_ms=round((time.monotonic() - started) * 1000, 2),
        )
        return response
