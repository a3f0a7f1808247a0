"""The vision node's configure surface (spec 000 §6.3, ARCHITECTURE.md §4.1) as an async port.

``VisionTasks`` is the port both MCP bridges code against; ``RosVisionTasks`` is the adapter
over the three ``ros2_vision_interfaces/srv/VisionTask`` services of a :class:`RosBridge`.
"""

from __future__ import annotations

import abc
import json
from typing import Any, Literal

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.errors import RemoteError

ManageAction = Literal["enable", "disable", "delete"]
DEFAULT_VISION_NODE = "vision_node"


def service_names(vision_node_name: str) -> dict[str, str]:
    """The three service names of a vision node: ``/{node}/create_vision_task`` etc."""
    base = "/" + vision_node_name.strip("/")
    return {
        "create": f"{base}/create_vision_task",
        "manage": f"{base}/manage_vision_task",
        "list": f"{base}/list_vision_tasks",
    }


def decode_reply(success: bool, message: str, service: str) -> dict[str, Any]:
    """Map a VisionTask reply to its JSON payload, or raise :class:`RemoteError`."""
    try:
        payload = json.loads(message) if message else {}
    except json.JSONDecodeError:
        payload = None
    if not success:
        if isinstance(payload, dict) and "error" in payload:
            return _raise_remote(str(payload["error"]), str(payload.get("detail", "")))
        return _raise_remote("vision_task_failed", message or f"{service} reported failure")
    if not isinstance(payload, dict):
        return _raise_remote("bad_reply", f"{service} answered with non-JSON-object {message!r}")
    return payload


def _raise_remote(code: str, detail: str) -> dict[str, Any]:
    raise RemoteError(code, detail)


class VisionTasks(abc.ABC):
    """create / manage / list skills on the vision node."""

    @abc.abstractmethod
    async def create(self, skill: dict[str, Any]) -> dict[str, Any]:
        """Create a skill; returns ``{"name", "topics": {...}}``."""

    @abc.abstractmethod
    async def manage(self, task_name: str, action: ManageAction) -> dict[str, Any]:
        """Enable, disable or delete a skill by name."""

    @abc.abstractmethod
    async def list(self) -> list[dict[str, Any]]:
        """Every skill the node runs: ``[{name, mode, enabled, once, topics, outputs, ...}]``."""


class RosVisionTasks(VisionTasks):
    """Adapter: the three VisionTask services through a :class:`RosBridge`."""

    def __init__(
        self,
        bridge: RosBridge,
        vision_node_name: str = DEFAULT_VISION_NODE,
        *,
        timeout_s: float = 5.0,
        wait_for_service_s: float = 3.0,
    ) -> None:
        from ros2_vision_interfaces.srv import VisionTask

        self._srv = VisionTask
        self._bridge = bridge
        self._timeout_s = timeout_s
        self._wait_s = wait_for_service_s
        names = service_names(vision_node_name)
        self._clients = {key: bridge.create_client(VisionTask, name) for key, name in names.items()}

    async def _call(self, key: str, data: dict[str, Any]) -> dict[str, Any]:
        client = self._clients[key]
        request = self._srv.Request()
        request.data = json.dumps(data)
        response = await self._bridge.call_service(
            client, request, self._timeout_s, wait_for_service_s=self._wait_s
        )
        return decode_reply(bool(response.success), str(response.message), client.service_name)

    async def create(self, skill: dict[str, Any]) -> dict[str, Any]:
        return await self._call("create", skill)

    async def manage(self, task_name: str, action: ManageAction) -> dict[str, Any]:
        return await self._call("manage", {"task_name": task_name, "action": action})

    async def list(self) -> list[dict[str, Any]]:
        payload = await self._call("list", {})
        skills = payload.get("skills", [])
        if not isinstance(skills, list):
            raise RemoteError("bad_reply", "list_vision_tasks 'skills' is not a list")
        return [s for s in skills if isinstance(s, dict)]
