"""The ``robot_sim`` node: Nav2's action, the map, the plan, the pose, odometry and the
camera, on timers."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import structlog
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from sensor_msgs.msg import CameraInfo, Image

from robot_sim import messages
from robot_sim.camera import Camera
from robot_sim.config import SimSettings
from robot_sim.drive import DriveSim
from robot_sim.gripper import Gripper
from robot_sim.manipulation_server import ManipulationServer
from robot_sim.nav2_server import NavigateToPoseServer
from robot_sim.render.renderer import camera_matrix
from robot_sim.supervisor_lock import ArmLockGate, SupervisorLockGate
from robot_sim.world_params import HELD, WorldParameters, objects_parameter

logger = structlog.get_logger(__name__)

NODE_NAME = "robot_sim"
MAP_TOPIC = "/map"
COSTMAP_TOPIC = "/global_costmap/costmap"
PLAN_TOPIC = "/plan"
PLAN_PERIOD_S = 1.0
"""Nav2's default behaviour tree replans (and publishes ``/plan``) once a second."""

AMCL_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""What AMCL publishes ``/amcl_pose`` with: a late subscriber gets the last pose at once."""
LATCHED_QOS = AMCL_QOS
"""map_server's ``/map`` and Nav2's costmap: reliable, transient local, the last one kept."""
PLAN_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)

CAMERA_QOS = QoSProfile(
    depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.BEST_EFFORT
)


class SimNode(Node):
    def __init__(
        self,
        settings: SimSettings,
        drive: DriveSim,
        camera: Camera,
        wall: Callable[[], float] = time.monotonic,
        context: Context | None = None,
    ) -> None:
        super().__init__(NODE_NAME, context=context)
        self.settings = settings
        self.drive = drive
        self.camera = camera
        self._wall = wall
        self.navigator = NavigateToPoseServer(
            self, drive, settings.action_name, settings.feedback_hz, wall, self._publish_image
        )
        self.gripper = Gripper(camera.world, settings.pick_max_age_s)
        self.parameters = WorldParameters(self, camera.world, self._set_active, self.gripper)
        self.manipulation = ManipulationServer(
            self,
            self.gripper,
            drive,
            settings.manipulation(),
            self._world_changed,
            wall,
        )
        self.lock: SupervisorLockGate | None = None
        self.arm_lock: ArmLockGate | None = None
        if settings.supervisor_lock:  # twist_mux's locks in front of the drive (issue 27)
            self.lock = SupervisorLockGate(
                self,
                drive,
                settings.supervisor_lock_topics,
                settings.supervisor_lock_timeout_s,
                wall,
                self.navigator.wake,
            )
            self.navigator.held = self.lock.locked
            # the arm's controller obeys its own server's lock (issue 39), not twist_mux's
            self.arm_lock = ArmLockGate(
                self, settings.arm_lock_topics, settings.supervisor_lock_timeout_s, wall
            )
            self.manipulation.held = self.arm_lock.locked
            self.manipulation.held_timeout_s = settings.progress_timeout_s
            self.navigator.progress_timeout_s = settings.progress_timeout_s
        self._amcl = self.create_publisher(PoseWithCovarianceStamped, "/amcl_pose", AMCL_QOS)
        self._odom = self.create_publisher(Odometry, "/odom", 10)
        self._map = self.create_publisher(OccupancyGrid, MAP_TOPIC, LATCHED_QOS)
        self._costmap = self.create_publisher(OccupancyGrid, COSTMAP_TOPIC, LATCHED_QOS)
        self._plan = self.create_publisher(Path, PLAN_TOPIC, PLAN_QOS)
        self._image = self.create_publisher(Image, settings.camera_topic, CAMERA_QOS)
        self._info = self.create_publisher(CameraInfo, settings.camera_info_topic, CAMERA_QOS)
        self._depth = self.create_publisher(Image, settings.depth_topic, CAMERA_QOS)
        self._last_view = ""
        self.on_pose_tick: Callable[[], None] = lambda: None
        self._image_lock = threading.Lock()
        self._costmap_version = -1
        self._plan_sent: tuple[tuple[float, float], ...] | None = None
        self._plan_at = 0.0
        self._plan_replans = -1
        stamp = self.get_clock().now().to_msg()
        self._map.publish(messages.occupancy_grid(camera.world.floor.grid, stamp))
        # Own groups: a slow camera frame never delays the pose.
        self.create_timer(
            1.0 / settings.pose_hz, self._publish_pose, MutuallyExclusiveCallbackGroup()
        )
        self.create_timer(
            1.0 / settings.camera_fps, self._publish_image, MutuallyExclusiveCallbackGroup()
        )
        logger.info(
            "robot_sim_ready",
            action=settings.action_name,
            camera_topic=settings.camera_topic,
            time_scale=settings.time_scale,
            scenes_dir=str(camera.store.directory),
        )

    def _set_active(self, active: bool) -> None:
        self.navigator.accepting = active

    def _world_changed(self, place: str) -> None:
        """The gripper moved something: the parameters say so, and the camera shows it."""
        world = self.camera.world
        self.set_parameters(
            [
                Parameter(
                    objects_parameter(place),
                    Parameter.Type.STRING_ARRAY,
                    list(world.objects_at(place)),
                ),
                Parameter(HELD, Parameter.Type.STRING, world.held() or ""),
            ]
        )
        self._publish_image()

    def _publish_pose(self) -> None:
        self.on_pose_tick()  # the stall watch (main.py): the process still runs
        if self.lock is not None:  # never a pose past the moment twist_mux held the base
            self.lock.enforce()
        state = self.drive.state(self._wall())
        stamp = self.get_clock().now().to_msg()
        self._amcl.publish(messages.amcl_pose(state.pose, stamp))
        self._odom.publish(messages.odometry(state.pose, state.speed_mps, stamp))
        robot_map = self.drive.robot_map
        if robot_map is not None and robot_map.version != self._costmap_version:
            self._costmap_version = robot_map.version
            self._costmap.publish(messages.occupancy_grid(robot_map.grid(), stamp))
            logger.info("costmap_updated", closed_doors=sorted(robot_map.known_closed))
        self._publish_plan(state.plan, state.replans, stamp)

    def _publish_plan(
        self, plan: tuple[tuple[float, float], ...], replans: int, stamp: object
    ) -> None:
        """A new plan at once, the plan ahead once a second while driving, and an empty path
        once the drive ended."""
        now = self._wall()
        if plan:
            fresh = self._plan_sent is None or not self._plan_sent or replans != self._plan_replans
            if not fresh and now - self._plan_at < PLAN_PERIOD_S:
                return
            if fresh and self._plan_sent and replans != self._plan_replans:
                via = [[round(x, 2), round(y, 2)] for x, y in plan]
                logger.info("path_replanned", replans=replans, waypoints=len(plan), via=via)
        elif not self._plan_sent:
            return
        self._plan_sent, self._plan_at, self._plan_replans = plan, now, replans
        self._plan.publish(messages.path(plan, stamp))

    def _publish_image(self) -> None:
        """One camera frame of where the robot is (the timer, and the navigator on a stop)."""
        with self._image_lock:
            state = self.drive.state(self._wall())
            depth = self._depth.get_subscription_count() > 0
            shot = self.camera.shot(state.pose, depth=depth, moving=state.driving)
            frame = shot.frame
            if frame.name != self._last_view:
                place = self.camera.place_at(state.pose)
                logger.info("camera_view", view=place or "driving", frame=frame.name)
                self._last_view = frame.name
            stamp = self.get_clock().now().to_msg()
            frame_id = self.settings.camera_frame_id
            self._image.publish(messages.image(frame, stamp, frame_id))
            fx, fy, cx, cy = camera_matrix(frame.width, frame.height)
            self._info.publish(
                messages.camera_info(frame.width, frame.height, fx, fy, cx, cy, stamp, frame_id)
            )
            if shot.depth is not None:
                self._depth.publish(messages.depth_image(shot.depth, stamp, frame_id))

    def destroy_node(self) -> None:
        self.navigator.destroy()
        self.manipulation.destroy()
        super().destroy_node()
