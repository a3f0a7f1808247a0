"""asyncio <-> rclpy bridge used by the MCP servers that talk ROS."""

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.errors import (
    BridgeClosedError,
    RemoteError,
    RosBridgeError,
    ServiceTimeoutError,
    ServiceUnavailableError,
)

__all__ = [
    "BridgeClosedError",
    "RemoteError",
    "RosBridge",
    "RosBridgeError",
    "ServiceTimeoutError",
    "ServiceUnavailableError",
]
