"""The ``robot_sim`` node: Nav2's action, the pose, odometry and the camera, on timers."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import structlog
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from sensor_msgs.msg import Image

from robot_sim import messages
from robot_sim.camera import Camera
from robot_sim.config import SimSettings
from robot_sim.drive import DriveSim
from robot_sim.nav2_server import NavigateToPoseServer
from robot_sim.supervisor_lock import SupervisorLockGate
from robot_sim.world_params import WorldParameters

logger = structlog.get_logger(__name__)

NODE_NAME = "robot_sim"

AMCL_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""What AMCL publishes ``/amcl_pose`` with: a late subscriber gets the last pose at once."""

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
        self.parameters = WorldParameters(self, camera.world, self._set_active)
        self.lock: SupervisorLockGate | None = None
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
        self._amcl = self.create_publisher(PoseWithCovarianceStamped, "/amcl_pose", AMCL_QOS)
        self._odom = self.create_publisher(Odometry, "/odom", 10)
        self._image = self.create_publisher(Image, settings.camera_topic, CAMERA_QOS)
        self._last_view = ""
        self._image_lock = threading.Lock()
        # Own groups: a slow camera frame (first render of a new scene) never delays the pose.
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

    def _publish_pose(self) -> None:
        if self.lock is not None:  # never a pose past the moment twist_mux held the base
            self.lock.enforce()
        state = self.drive.state(self._wall())
        stamp = self.get_clock().now().to_msg()
        self._amcl.publish(messages.amcl_pose(state.pose, stamp))
        self._odom.publish(messages.odometry(state.pose, state.speed_mps, stamp))

    def _publish_image(self) -> None:
        """One camera frame of where the robot is (the timer, and the navigator on a stop)."""
        with self._image_lock:
            state = self.drive.state(self._wall())
            view = self.camera.view_of(state.pose, state.driving)
            frame = self.camera.frame(view)
            if frame.name != self._last_view:
                logger.info("camera_view", view=view, frame=frame.name)
                self._last_view = frame.name
            stamp = self.get_clock().now().to_msg()
            self._image.publish(messages.image(frame, stamp, self.settings.camera_frame_id))

    def destroy_node(self) -> None:
        self.navigator.destroy()
        super().destroy_node()
