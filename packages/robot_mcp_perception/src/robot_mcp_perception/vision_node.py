"""The ROS 2 vision node (spec 000 §6, §7): services, per-skill publishers, diagnostics.

Threads: the ROS executor (services, timers, camera callbacks), the frame source's own
reader thread (folder/v4l2/rtsp), the model loop (scheduler). Results are published from the
model loop thread (rclpy publish is thread-safe); the skill engine's lock guards skill state.
"""

from __future__ import annotations

import json
import sys
import time
from collections import deque
from functools import partial
from typing import Any, NoReturn

import rclpy
import structlog
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from ros2_vision_interfaces.msg import StampedString
from ros2_vision_interfaces.srv import VisionTask
from std_msgs.msg import Header

from robot_mcp_perception.artifacts import ArtifactServer, ArtifactStore, build_app
from robot_mcp_perception.conversions import frame_header, json_to_msg, ns_to_stamp
from robot_mcp_perception.cost import CostPolicy, PrewarmCache
from robot_mcp_perception.engine import SkillEngine
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.frames_ros import RosFrameSource
from robot_mcp_perception.health import HealthSources, health_report
from robot_mcp_perception.pipelines import grounder_requests
from robot_mcp_perception.pipelines.common import PipelineContext, PipelineSettings, SkillResult
from robot_mcp_perception.provenance import Provenance
from robot_mcp_perception.publishers import DIAGNOSTICS_QOS, SkillPublishers
from robot_mcp_perception.registry import SkillRegistry, SkillState, topics_for
from robot_mcp_perception.runtime import Runtime
from robot_mcp_perception.scheduler import Scheduler
from robot_mcp_perception.settings import (
    ROS_PARAMETERS,
    NodeSettings,
    StartupError,
    node_settings_with,
)
from robot_mcp_perception.skills import Skill, SkillError, SkillOutput
from robot_mcp_perception.task_service import Operation, TaskService, serve
from robot_ros_bridge.spinning import spin_until_shutdown

logger = structlog.get_logger("robot_mcp_perception.vision_node")

AMBIENT_OUTPUTS = (
    SkillOutput("scene_description", "text", "a detailed description of the scene"),
    SkillOutput("scene_objects", "list", "the main objects, up to 10"),
)
"""What ambient_scene publishes: the output names the perception buffer reads for
``what_do_you_see`` (its scene description and object list)."""


class VisionNode(Node):
    def __init__(self, runtime: Runtime, *, context: Context | None = None) -> None:
        settings = runtime.settings
        super().__init__(settings.node.node_name, context=context)
        self.runtime = runtime
        self.node_settings = self._validated_parameters()
        self.namespace: str = self.node_settings.topic_namespace
        self._follow_camera_topic()
        self.registry = SkillRegistry()
        self.scheduler = Scheduler(
            workers=self.node_settings.workers,
            max_in_flight=self.node_settings.max_in_flight,
            timeout_s=self.node_settings.model_timeout_s,
        )
        self.policy = CostPolicy(settings.cost)
        self.prewarm = PrewarmCache(settings.prewarm.prewarm_ttl_s)
        art = settings.artifacts
        self.artifacts = ArtifactStore(
            f"http://{art.host}:{art.port}",
            art.masks_per_skill,
            art.overlays_per_skill,
            runtime.overlay_renderer,
            art.deleted_skills_kept,
        )
        pipeline_settings = runtime.pipeline_settings or PipelineSettings()
        self.engine = SkillEngine(
            registry=self.registry,
            scheduler=self.scheduler,
            policy=self.policy,
            prewarm=self.prewarm,
            context=PipelineContext(runtime.grounder, runtime.segmenter, pipeline_settings),
            runner=runtime.runner,
            sink=self,
            default_rate_hz=self.node_settings.processing_frequency,
            scene_reference=(
                partial(runtime.gate_factory, settings.watch.gate_threshold)
                if runtime.gate_factory
                else None
            ),
            grounder_requests=partial(grounder_requests, settings=pipeline_settings),
            fresh_frame_wait_s=self.node_settings.fresh_frame_wait_s,
        )
        self.tasks = TaskService(
            self.registry,
            self.namespace,
            attach=self._attach,
            detach=self._detach,
            make_state=self._make_state,
        )
        self.latencies_ms: deque[float] = deque(maxlen=512)
        self._started = time.monotonic()
        self._closing = False  # set first in shutdown(): no publishing from then on
        self._stats_pub = self.create_publisher(
            StampedString, f"{self.namespace}/stats", DIAGNOSTICS_QOS
        )
        self._latency_pub = self.create_publisher(
            StampedString, f"{self.namespace}/latency", DIAGNOSTICS_QOS
        )
        services = MutuallyExclusiveCallbackGroup()
        for name, operation in (
            ("create_vision_task", self.tasks.create),
            ("manage_vision_task", self.tasks.manage),
            ("list_vision_tasks", self.tasks.list),
        ):
            self.create_service(
                VisionTask, f"~/{name}", self._service(name, operation), callback_group=services
            )
        timers = MutuallyExclusiveCallbackGroup()
        self.create_timer(1.0 / settings.node.tick_hz, self._tick, callback_group=timers)
        self.create_timer(settings.node.stats_period_s, self.publish_stats, callback_group=timers)
        self._server: ArtifactServer | None = None
        if art.enabled and runtime.serve_artifacts:  # first: a busy port stops us before work
            self._server = ArtifactServer(
                build_app(
                    self.artifacts,
                    self.health,
                    runtime.frame_source.latest,
                    auth=runtime.artifacts_auth,
                ),
                art.host,
                art.port,
            )
            self._server.start()
            if runtime.artifacts_auth.open:
                logger.warning(
                    "artifacts_auth_disabled", detail="ARTIFACTS_AUTH=off: pictures open"
                )
            elif runtime.artifacts_auth.token is None:
                logger.warning(
                    "artifacts_auth_unconfigured",
                    detail="no ARTIFACTS_AUTH_TOKEN: every picture is refused (401)",
                )
        self.scheduler.start()
        self._create_default_skills()
        runtime.frame_source.start(self, on_frame=self.engine.dispatch)
        logger.info("vision_node_started", namespace=self.namespace, skills=len(self.registry))

    # -- parameters and start-up skills -------------------------------------------------
    def _validated_parameters(self) -> NodeSettings:
        """The ROS parameters (spec 000 §7) over the Hydra node settings, through the same
        Pydantic validation (StartupError on a bad value). Typing is dynamic so that
        ``processing_frequency:=0`` reaches the validation instead of an rclpy type error."""
        node = self.runtime.settings.node
        defaults = {**node.model_dump(), "default_skills": json.dumps(node.default_skills)}
        dynamic = ParameterDescriptor(dynamic_typing=True)
        for name in ROS_PARAMETERS:
            self.declare_parameter(name, defaults[name], dynamic)
        values = {name: self.get_parameter(name).value for name in ROS_PARAMETERS}
        return node_settings_with(node, values)

    def _follow_camera_topic(self) -> None:
        """A camera_topic ROS parameter / launch argument moves the ROS frame source to it."""
        source = self.runtime.frame_source
        topic = self.node_settings.camera_topic
        if isinstance(source, RosFrameSource) and topic != self.runtime.settings.node.camera_topic:
            logger.info("camera_topic_selected", topic=topic, configured=source.topic)
            source.topic = topic

    def _create_default_skills(self) -> None:
        """Validated at start-up (``NodeSettings.default_skills``): creating them cannot fail."""
        ambient = self.runtime.settings.cost.ambient_scene
        for data in self.node_settings.default_skills:
            ok, message = serve("create_vision_task", self.tasks.create, json.dumps(data))
            if not ok and not self.context.ok():
                raise ExternalShutdownException  # stopped while starting: a normal stop
            if not ok:  # pragma: no cover - only a duplicate of ambient_scene's name
                raise StartupError(f"default skill {data.get('name')!r} refused: {message}")
        if ambient.enabled:
            skill = Skill(
                name=ambient.name,
                mode="describe",
                description="ambient scene description (cost.ambient_scene)",
                grounding=ambient.grounding,
                outputs=AMBIENT_OUTPUTS,
                rate_hz=ambient.rate_hz,
            )
            ok, message = serve("create_vision_task", self.tasks.create, skill.to_json())
            if ok:
                self.registry.get(ambient.name).always_gated = True
            elif not self.context.ok():
                raise ExternalShutdownException
            else:
                logger.error("ambient_scene_rejected", reply=message)

    # -- services ---------------------------------------------------------------------------
    def _service(self, name: str, operation: Operation) -> Any:
        def callback(request: VisionTask.Request, response: VisionTask.Response) -> Any:
            with self.engine.lock:
                response.success, response.message = serve(name, operation, request.data)
            return response

        return callback

    def _make_state(self, skill: Skill) -> SkillState:
        gate_factory = self.runtime.gate_factory
        threshold = self.runtime.settings.watch.gate_threshold
        return SkillState(
            skill,
            topics_for(self.namespace, skill),
            gate=gate_factory(threshold) if gate_factory else None,
        )

    def _attach(self, state: SkillState) -> None:
        try:
            state.publishers = SkillPublishers(self, state.skill.name, state.topics)
        except Exception:
            if self.context.ok():
                raise
            # a stop (SIGINT/SIGTERM) during start-up invalidated the context: no traceback
            raise SkillError("shutting_down", "the vision node is shutting down") from None

    def _detach(self, state: SkillState) -> None:
        if isinstance(state.publishers, SkillPublishers):
            state.publishers.destroy()
        self.artifacts.retire(state.skill.name)
        self.policy.forget(state.skill.name)

    # -- frames and results -------------------------------------------------------------------
    def _tick(self) -> None:
        self.engine.tick(self.runtime.frame_source.latest())

    def publish(
        self, state: SkillState, frame: Frame, result: SkillResult, provenance: Provenance
    ) -> None:
        """ResultSink: called by the engine with its lock held. Nothing is published once the
        node is closing or its ROS context is gone (a signal shuts the context before
        ``shutdown`` cancels the model runs, whose failure would republish a stale result)."""
        publishers = state.publishers
        if not isinstance(publishers, SkillPublishers) or self._closing or not self.context.ok():
            return
        render: Any = None
        if not provenance.stale:
            refs = self.artifacts.add(state.skill.name, state.topics.detections, frame, result)
            state.last_extras = [{"mask_ref": ref} if ref else {} for ref in refs]
            renderer = self.runtime.overlay_renderer
            render = (lambda: renderer(frame.image, result)) if renderer else (lambda: frame.image)
        marks = provenance.detection_marks()
        extras = [{**extra, **marks} for extra in state.last_extras]
        outputs_header = None
        if provenance.grounding_stamp_ns is not None:  # outputs come from the grounding frame
            outputs_header = Header(
                stamp=ns_to_stamp(provenance.grounding_stamp_ns),
                frame_id=provenance.grounding_frame_id or frame.frame_id,
            )
        published = publishers.publish(
            frame, result, extras, render, provenance.result_extra(), outputs_header
        )
        if not published:
            return
        state.published += 1
        state.last_publish_wall = time.monotonic()
        if not provenance.stale:
            state.last_published_stamp_ns = frame.stamp_ns
            latency_ms = (time.time_ns() - frame.stamp_ns) / 1e6
            self.latencies_ms.append(latency_ms)
            self._latency_pub.publish(
                json_to_msg(
                    {
                        "skill": state.skill.name,
                        "latency_ms": round(latency_ms, 3),
                        "timings_ms": result.timings_ms,
                    },
                    frame_header(frame),
                )
            )

    # -- diagnostics --------------------------------------------------------------------------
    def health(self) -> dict[str, Any]:
        return health_report(
            HealthSources(
                node_name=self.get_name(),
                started=self._started,
                frame_stale_after_s=self.node_settings.frame_stale_after_s,
                frame_source=self.runtime.frame_source,
                grounder=self.runtime.grounder,
                segmenter=self.runtime.segmenter,
                scheduler=self.scheduler,
                policy=self.policy,
                registry=self.registry,
            )
        )

    def stats(self) -> dict[str, Any]:
        latencies = sorted(self.latencies_ms)
        return {
            "skills": {
                s.skill.name: {
                    "enabled": s.enabled,
                    "runs": s.runs,
                    "published": s.published,
                    "failures": s.failures,
                    "skips": dict(s.skips),
                }
                for s in self.registry.states()
            },
            "scheduler": self.scheduler.stats.as_dict(),
            "in_flight": self.scheduler.in_flight,
            "cloud_calls_last_min": self.policy.budget.used(),
            "cloud_calls_total": self.policy.budget.total,
            "latency_p50_ms": round(latencies[len(latencies) // 2], 3) if latencies else None,
            "prewarm_entries": len(self.prewarm),
        }

    def publish_stats(self) -> None:
        payload = self.stats()
        header = Header(stamp=ns_to_stamp(time.time_ns()), frame_id="")
        self._stats_pub.publish(json_to_msg(payload, header))
        logger.info("vision_stats", **payload)

    def shutdown(self) -> None:
        """Stop the frame source, the model loop and the artifacts server (bounded time)."""
        self._closing = True
        self.runtime.frame_source.stop()
        self.scheduler.stop()
        if self._server is not None:
            self._server.stop()
        for state in self.registry.states():
            self._detach(state)


def _refuse_to_start(error: StartupError) -> NoReturn:
    """Exit code 2 and one line naming the problem (no traceback, no JSON log line)."""
    line = " ".join(str(error).split())
    print(f"vision_node: {line}", file=sys.stderr)  # noqa: T201 - the operator's fix-it line
    sys.exit(2)


def main(args: list[str] | None = None) -> None:
    from robot_mcp_perception.composition import build_runtime_from_env

    try:
        runtime = build_runtime_from_env()
    except StartupError as error:
        _refuse_to_start(error)
    try:
        rclpy.init(args=args)
    except Exception as error:  # start-up boundary: rcl refuses malformed --ros-args
        _refuse_to_start(StartupError(f"cannot parse the ROS arguments: {error}"))
    node: VisionNode | None = None
    executor = MultiThreadedExecutor(num_threads=4)
    try:
        node = VisionNode(runtime)
        executor.add_node(node)
        spin_until_shutdown(executor)  # a skill's entities destroyed mid-wait do not end it
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except StartupError as error:
        _refuse_to_start(error)
    finally:
        if node is not None:
            node.shutdown()
            node.destroy_node()
        executor.shutdown(timeout_sec=2.0)
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
