"""A fake vision node for tests and benchmarks: a real rclpy node that serves the three
VisionTask services with an in-memory skill table and publishes on the real topic names.

It is the test double at the ROS boundary of the MCP bridges (not a mock of rclpy): clients
discover it through the ROS graph exactly as they discover the real ``vision_node``.
"""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.errors import RemoteError, RosBridgeError
from robot_ros_bridge.vision_tasks import (
    DEFAULT_VISION_NODE,
    ManageAction,
    VisionTasks,
    service_names,
)

NS = "/vision"


@dataclass
class _SkillEntry:
    spec: dict[str, Any]
    enabled: bool = True
    publishers: dict[str, Any] = field(default_factory=dict)


def skill_topics(name: str, outputs: list[str]) -> dict[str, Any]:
    return {
        "detections": f"{NS}/{name}/detections",
        "detections_meta": f"{NS}/{name}/detections_meta",
        "overlay": f"{NS}/{name}/overlay",
        "outputs": {out: f"{NS}/{name}/{out}" for out in outputs},
    }


class FakeVisionNode:
    """Serves ``/{name}/create_vision_task`` / ``manage_vision_task`` / ``list_vision_tasks``.

    ``requests`` records every ``(service, payload)``; ``fail_next[service] = (code, detail)``
    makes the next call of that service answer ``success=false``; ``reply_delay_s`` delays
    every answer (to exercise client timeouts) and ``reply_delays[service]`` one service's
    (``"create"``: the skill is created after the delay, as a slow node would — the client
    may have given up by then); ``auto_publish_hz`` publishes one synthetic
    detection (+ outputs) per enabled skill at that rate.
    """

    def __init__(
        self,
        name: str = DEFAULT_VISION_NODE,
        *,
        reply_delay_s: float = 0.0,
        reply_delays: dict[str, float] | None = None,
        auto_publish_hz: float | None = None,
    ) -> None:
        self.name = name
        self.reply_delay_s = reply_delay_s
        self.reply_delays: dict[str, float] = dict(reply_delays or {})
        self.requests: list[tuple[str, dict[str, Any]]] = []
        self.fail_next: dict[str, tuple[str, str]] = {}
        self._bridge = RosBridge(name, num_threads=4)
        self._skills: dict[str, _SkillEntry] = {}
        self._lock = threading.RLock()
        self._auto_publish_hz = auto_publish_hz
        self._services: list[Any] = []

    # -- lifecycle -----------------------------------------------------------------------
    def start(self) -> FakeVisionNode:
        from ros2_vision_interfaces.srv import VisionTask

        self._bridge.start()
        node = self._bridge.node
        for key, srv_name in service_names(self.name).items():
            self._services.append(
                self._bridge.create_service(VisionTask, srv_name, self._handler(key))
            )
        if self._auto_publish_hz:
            node.create_timer(1.0 / self._auto_publish_hz, self._auto_publish)
        return self

    def close(self) -> None:
        self._bridge.close()

    def __enter__(self) -> FakeVisionNode:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- state ---------------------------------------------------------------------------
    def skills(self) -> dict[str, dict[str, Any]]:
        with self._lock:
            return {name: dict(entry.spec) for name, entry in self._skills.items()}

    def enabled(self, name: str) -> bool:
        with self._lock:
            return self._skills[name].enabled

    # -- services ------------------------------------------------------------------------
    def _handler(self, key: str) -> Any:
        def handle(request: Any, response: Any) -> Any:
            try:
                data = json.loads(request.data or "{}")
            except json.JSONDecodeError:
                data = {"_raw": request.data}
            self.requests.append((key, data))
            delay = self.reply_delays.get(key, self.reply_delay_s)
            if delay:
                time.sleep(delay)
            failure = self.fail_next.pop(key, None)
            if failure is not None:
                return _reply(response, False, {"error": failure[0], "detail": failure[1]})
            try:
                payload = getattr(self, f"_do_{key}")(data)
            except _Refused as refused:
                return _reply(response, False, {"error": refused.code, "detail": refused.detail})
            return _reply(response, True, payload)

        return handle

    def _do_create(self, data: dict[str, Any]) -> dict[str, Any]:
        from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

        name = data.get("name")
        mode = data.get("mode")
        if not isinstance(name, str) or not name:
            raise _Refused("invalid_skill", "a skill needs a non-empty 'name'")
        if mode not in ("describe", "ground_and_segment", "segment_all", "region"):
            raise _Refused("invalid_skill", f"unknown mode {mode!r}")
        outputs = [str(o["name"]) for o in data.get("outputs", []) if isinstance(o, dict)]
        with self._lock:
            if name in self._skills:
                raise _Refused("duplicate_name", f"a skill named {name!r} already exists")
            topics = skill_topics(name, outputs)
            node = self._bridge.node
            entry = _SkillEntry(spec=dict(data))
            entry.publishers["detections"] = node.create_publisher(
                VisionDetectionArray, topics["detections"], 10
            )
            entry.publishers["detections_meta"] = node.create_publisher(
                VisionDetectionArray, topics["detections_meta"], 10
            )
            for out in outputs:
                entry.publishers[f"out:{out}"] = node.create_publisher(
                    StampedString, topics["outputs"][out], 10
                )
            self._skills[name] = entry
        return {"name": name, "topics": topics}

    def _do_manage(self, data: dict[str, Any]) -> dict[str, Any]:
        name, action = data.get("task_name"), data.get("action")
        with self._lock:
            entry = self._skills.get(str(name))
            if entry is None:
                raise _Refused("unknown_skill", f"no skill named {name!r}")
            if action == "delete":
                for pub in entry.publishers.values():
                    self._bridge.node.destroy_publisher(pub)
                del self._skills[str(name)]
            elif action in ("enable", "disable"):
                entry.enabled = action == "enable"
            else:
                raise _Refused("invalid_action", f"unknown action {action!r}")
        return {"name": name, "action": action}

    def _do_list(self, _data: dict[str, Any]) -> dict[str, Any]:
        with self._lock:
            skills = []
            for name, entry in self._skills.items():
                outputs = [o for o in entry.spec.get("outputs", []) if isinstance(o, dict)]
                info = {
                    "name": name,
                    "mode": entry.spec.get("mode"),
                    "enabled": entry.enabled,
                    "once": bool(entry.spec.get("once", False)),
                    "outputs": outputs,
                    "topics": skill_topics(name, [str(o["name"]) for o in outputs]),
                }
                if "watch" in entry.spec:
                    info["watch"] = entry.spec["watch"]
                skills.append(info)
        return {"skills": skills}

    # -- publishing ----------------------------------------------------------------------
    def publish_detections(
        self, skill: str, detections: list[dict[str, Any]], stamp_s: float | None = None
    ) -> None:
        """Publish one result on ``/detections`` (with a small mask) and ``/detections_meta``.

        Each detection dict: ``label``, ``score``, ``kind``, ``box`` ``[x, y, w, h]``,
        ``point`` ``[x, y]``, ``extra`` (dict).
        """
        full, meta = self._arrays(skill, detections, stamp_s)
        with self._lock:
            pubs = self._skills[skill].publishers
            pubs["detections"].publish(full)
            pubs["detections_meta"].publish(meta)

    def publish_output(
        self, skill: str, output: str, value: Any, stamp_s: float | None = None
    ) -> None:
        from ros2_vision_interfaces.msg import StampedString

        msg = StampedString()
        _stamp(msg.header, stamp_s)
        msg.data = json.dumps(value)
        with self._lock:
            self._skills[skill].publishers[f"out:{output}"].publish(msg)

    def _arrays(
        self, skill: str, detections: list[dict[str, Any]], stamp_s: float | None
    ) -> tuple[Any, Any]:
        from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

        arrays = []
        for with_mask in (True, False):
            array = VisionDetectionArray()
            _stamp(array.header, stamp_s)
            array.header.frame_id = "camera"
            array.skill = skill
            for det in detections:
                msg = VisionDetection()
                msg.label = str(det.get("label", ""))
                msg.score = float(det.get("score", 1.0))
                msg.kind = str(det.get("kind", "object"))
                x, y, w, h = (int(v) for v in det.get("box", [0, 0, 0, 0]))
                msg.box.x_offset, msg.box.y_offset, msg.box.width, msg.box.height = x, y, w, h
                px, py = det.get("point", [x + w / 2, y + h / 2])
                msg.point.x, msg.point.y = float(px), float(py)
                msg.extra = json.dumps(det.get("extra", {}))
                if with_mask:
                    msg.mask.height, msg.mask.width = 4, 4
                    msg.mask.encoding = "mono8"
                    msg.mask.step = 4
                    msg.mask.data = bytes([255] * 16)
                array.detections.append(msg)
            arrays.append(array)
        return arrays[0], arrays[1]

    def _auto_publish(self) -> None:
        with self._lock:
            names = [(name, entry.spec) for name, entry in self._skills.items() if entry.enabled]
        for name, spec in names:
            label = str(spec.get("grounding") or spec.get("mode") or name)
            try:
                self.publish_detections(
                    name, [{"label": label, "score": 0.9, "box": [10, 20, 30, 40]}]
                )
                for out in spec.get("outputs", []):
                    if isinstance(out, dict):
                        self.publish_output(name, str(out["name"]), _default_value(out))
            except KeyError:  # deleted between the snapshot and the publish
                continue


class FakeVisionTasks(VisionTasks):
    """In-memory fake of the :class:`VisionTasks` port (no ROS): records every call.

    ``fail_with`` makes every call raise that error (e.g. ``ServiceUnavailableError``).
    """

    def __init__(self) -> None:
        self.calls: list[tuple[str, Any]] = []
        self.skills: dict[str, dict[str, Any]] = {}
        self.enabled: dict[str, bool] = {}
        self.fail_with: RosBridgeError | None = None

    def _check(self, call: str, arg: Any) -> None:
        self.calls.append((call, arg))
        if self.fail_with is not None:
            raise self.fail_with

    async def create(self, skill: dict[str, Any]) -> dict[str, Any]:
        self._check("create", skill)
        name = str(skill["name"])
        if name in self.skills:
            raise RemoteError("duplicate_name", f"a skill named {name!r} already exists")
        self.skills[name] = dict(skill)
        self.enabled[name] = True
        outputs = [str(o["name"]) for o in skill.get("outputs", [])]
        return {"name": name, "topics": skill_topics(name, outputs)}

    async def manage(self, task_name: str, action: ManageAction) -> dict[str, Any]:
        self._check("manage", {"task_name": task_name, "action": action})
        if task_name not in self.skills:
            raise RemoteError("unknown_skill", f"no skill named {task_name!r}")
        if action == "delete":
            del self.skills[task_name]
            del self.enabled[task_name]
        else:
            self.enabled[task_name] = action == "enable"
        return {"name": task_name, "action": action}

    async def list(self) -> list[dict[str, Any]]:
        self._check("list", None)
        listed = []
        for name, spec in self.skills.items():
            outputs = list(spec.get("outputs", []))
            info = {
                "name": name,
                "mode": spec.get("mode"),
                "enabled": self.enabled[name],
                "once": bool(spec.get("once", False)),
                "outputs": outputs,
                "topics": skill_topics(name, [str(o["name"]) for o in outputs]),
            }
            if "watch" in spec:
                info["watch"] = spec["watch"]
            listed.append(info)
        return listed


class _Refused(Exception):
    def __init__(self, code: str, detail: str) -> None:
        super().__init__(detail)
        self.code, self.detail = code, detail


def _reply(response: Any, success: bool, payload: dict[str, Any]) -> Any:
    response.success = success
    response.message = json.dumps(payload)
    return response


def _stamp(header: Any, stamp_s: float | None) -> None:
    now = time.time() if stamp_s is None else stamp_s
    header.stamp.sec = int(now)
    header.stamp.nanosec = int((now - int(now)) * 1e9)


def _default_value(output: dict[str, Any]) -> Any:
    return {"boolean": False, "number": 0.0, "list": [], "text": ""}.get(str(output.get("type")))


def main(argv: list[str] | None = None) -> None:
    """``python -m robot_stack_testing.ros.fake_vision [--name N] [--hz R]``: run a fake vision node
    until SIGINT/SIGTERM (for cross-process tests and benchmarks)."""
    import argparse
    import signal

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--name", default=DEFAULT_VISION_NODE)
    parser.add_argument("--hz", type=float, default=None, help="auto-publish rate per skill")
    args = parser.parse_args(argv)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    with FakeVisionNode(args.name, auto_publish_hz=args.hz):
        stop.wait()


if __name__ == "__main__":
    main()
