"""One rclpy Context + Node + MultiThreadedExecutor spinning in a daemon thread, and the
asyncio side of it (ARCHITECTURE.md §3).

Service futures are handed to the event loop with ``call_soon_threadsafe`` and awaited under
``asyncio.wait_for``; a timed-out request is removed from the client's pending table. A
service nobody serves is a fast, clean :class:`ServiceUnavailableError`, never a hang.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import rclpy
import structlog
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile

from robot_ros_bridge.errors import BridgeClosedError, ServiceTimeoutError, ServiceUnavailableError

logger = structlog.get_logger(__name__)

T = TypeVar("T")
_SERVICE_POLL_S = 0.05


class RosBridge:
    """Owns the ROS side of one process. Thread-safe; create once in the composition root.

    Use as a context manager or call :meth:`start` / :meth:`close`.
    """

    def __init__(
        self,
        node_name: str,
        *,
        namespace: str = "",
        num_threads: int = 2,
        args: Sequence[str] | None = None,
    ) -> None:
        self._node_name = node_name
        self._namespace = namespace
        self._num_threads = num_threads
        self._args = list(args) if args is not None else []
        self._context: Context | None = None
        self._node: Node | None = None
        self._executor: MultiThreadedExecutor | None = None
        self._thread: threading.Thread | None = None
        self._group = ReentrantCallbackGroup()
        self._closed = False

    # -- lifecycle -----------------------------------------------------------------------
    def start(self) -> RosBridge:
        if self._closed:
            raise BridgeClosedError("the ROS bridge was closed and cannot be restarted")
        if self._context is not None:
            return self
        context = Context()
        rclpy.init(context=context, args=self._args)
        node = Node(self._node_name, namespace=self._namespace, context=context)
        executor = MultiThreadedExecutor(num_threads=self._num_threads, context=context)
        executor.add_node(node)
        self._context, self._node, self._executor = context, node, executor
        self._thread = threading.Thread(
            target=self._spin, name=f"ros-spin-{self._node_name}", daemon=True
        )
        self._thread.start()
        logger.info("ros_bridge_started", node=node.get_fully_qualified_name())
        return self

    def _spin(self) -> None:
        executor = self._executor
        assert executor is not None
        try:
            executor.spin()
        except ExternalShutdownException:
            pass
        except Exception:  # the spin thread is a process boundary
            logger.exception("ros_spin_crashed")

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop spinning, destroy the node, shut the context down. Idempotent."""
        if self._closed:
            return
        self._closed = True
        executor, node, context, thread = self._executor, self._node, self._context, self._thread
        if executor is not None:
            executor.shutdown(timeout_sec=timeout_s)
        if node is not None:
            node.destroy_node()
        if context is not None:
            context.try_shutdown()
        if thread is not None:
            thread.join(timeout=timeout_s)
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
        """A service client in the bridge's reentrant callback group."""
        return self.node.create_client(srv_type, service_name, callback_group=self._group)

    def create_service(
        self, srv_type: Any, service_name: str, handler: Callable[[Any, Any], Any]
    ) -> Any:
        """A service server whose handler may run concurrently with other callbacks."""
        return self.node.create_service(srv_type, service_name, handler, callback_group=self._group)

    def create_subscription(
        self,
        msg_type: Any,
        topic: str,
        callback: Callable[[Any], None],
        qos: QoSProfile | int = 10,
    ) -> Any:
        """A subscription whose callback runs on an executor thread (keep it short)."""
        return self.node.create_subscription(
            msg_type, topic, callback, qos, callback_group=self._group
        )

    def destroy_subscription(self, subscription: Any) -> None:
        if not self._closed and self._node is not None:
            self._node.destroy_subscription(subscription)

    def create_publisher(self, msg_type: Any, topic: str, qos: QoSProfile | int = 10) -> Any:
        return self.node.create_publisher(msg_type, topic, qos)

    # -- graph ---------------------------------------------------------------------------
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
        No answer within ``timeout_s`` (measured from the call) raises
        :class:`ServiceTimeoutError` and drops the pending request.
        """
        if self._closed or self._node is None:
            raise BridgeClosedError("the ROS bridge is closed")
        service = client.service_name
        started = time.monotonic()
        deadline = started + timeout_s
        wait_deadline = started + min(wait_for_service_s, timeout_s)
        while not client.service_is_ready():
            if time.monotonic() >= wait_deadline:
                raise ServiceUnavailableError(
                    f"no server for {service} (is the node running in this ROS domain?)"
                )
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
            response = await asyncio.wait_for(answer, timeout=remaining)
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
