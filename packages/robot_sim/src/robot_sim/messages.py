"""Domain → ROS message conversion as pure functions (no node, no publishing).

``Image.data`` is always filled with ``bytes``: a numpy array there costs ~50 ms per message
(ARCHITECTURE §3).
"""

from __future__ import annotations

import array
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Pose as PoseMsg
from geometry_msgs.msg import (
    PoseStamped,
    PoseWithCovarianceStamped,
    Quaternion,
)
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry, Path
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Header

from robot_sim.floor.grid import Grid
from robot_sim.store import StoredFrame
from robot_site_map import Pose

MAP_FRAME = "map"
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"

POSE_COVARIANCE = tuple(0.0025 if i in (0, 7) else 0.0007 if i == 35 else 0.0 for i in range(36))
"""x/y ±5 cm, yaw ±1.5° (1σ): a well-localised robot, as AMCL reports one."""


def yaw_to_quaternion(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def quaternion_to_yaw(q: Quaternion) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def seconds_to_duration(seconds: float) -> Duration:
    nanos = max(0, round(seconds * 1e9))
    return Duration(sec=nanos // 1_000_000_000, nanosec=nanos % 1_000_000_000)


def pose_msg(pose: Pose) -> PoseMsg:
    msg = PoseMsg()
    msg.position.x, msg.position.y = float(pose.x), float(pose.y)
    msg.orientation = yaw_to_quaternion(pose.theta)
    return msg


def pose_from_msg(msg: PoseMsg) -> Pose:
    return Pose(float(msg.position.x), float(msg.position.y), quaternion_to_yaw(msg.orientation))


def pose_stamped(pose: Pose, stamp: Time, frame: str = MAP_FRAME) -> PoseStamped:
    return PoseStamped(header=Header(stamp=stamp, frame_id=frame), pose=pose_msg(pose))


def amcl_pose(pose: Pose, stamp: Time) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped(header=Header(stamp=stamp, frame_id=MAP_FRAME))
    msg.pose.pose = pose_msg(pose)
    msg.pose.covariance = list(POSE_COVARIANCE)
    return msg


def odometry(pose: Pose, speed_mps: float, stamp: Time) -> Odometry:
    """The sim's odometry does not drift: ``odom`` coincides with ``map``."""
    msg = Odometry(header=Header(stamp=stamp, frame_id=ODOM_FRAME), child_frame_id=BASE_FRAME)
    msg.pose.pose = pose_msg(pose)
    msg.pose.covariance = list(POSE_COVARIANCE)
    msg.twist.twist.linear.x = float(speed_mps)
    return msg


def image(frame: StoredFrame, stamp: Time, frame_id: str) -> Image:
    msg = Image(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=frame.height,
        width=frame.width,
        encoding="rgb8",
        step=frame.width * 3,
    )
    msg.data = frame.data
    return msg


def occupancy_grid(grid: Grid, stamp: Time, frame: str = MAP_FRAME) -> OccupancyGrid:
    """The grid as map_server publishes it (row-major from the map's lower-left cell)."""
    info = MapMetaData(
        map_load_time=stamp,
        resolution=float(grid.resolution),
        width=grid.width,
        height=grid.height,
    )
    info.origin.position.x, info.origin.position.y = float(grid.origin[0]), float(grid.origin[1])
    info.origin.orientation.w = 1.0
    msg = OccupancyGrid(header=Header(stamp=stamp, frame_id=frame), info=info)
    msg.data = array.array("b", grid.cells.tobytes())
    return msg


def path(points: Sequence[tuple[float, float]], stamp: Time, frame: str = MAP_FRAME) -> Path:
    """A nav_msgs/Path of waypoints, each facing the next (the last keeps its predecessor's)."""
    msg = Path(header=Header(stamp=stamp, frame_id=frame))
    poses = []
    for i, (x, y) in enumerate(points):
        ahead = points[i + 1] if i + 1 < len(points) else None
        behind = points[i - 1] if i > 0 else None
        if ahead is not None:
            yaw = math.atan2(ahead[1] - y, ahead[0] - x)
        elif behind is not None:
            yaw = math.atan2(y - behind[1], x - behind[0])
        else:
            yaw = 0.0
        poses.append(pose_stamped(Pose(x, y, yaw), stamp, frame))
    msg.poses = poses
    return msg


def camera_info(
    width: int, height: int, fx: float, fy: float, cx: float, cy: float, stamp: Time, frame_id: str
) -> CameraInfo:
    """An ideal pinhole camera (no distortion), as ``camera_info_manager`` publishes one."""
    msg = CameraInfo(header=Header(stamp=stamp, frame_id=frame_id), width=width, height=height)
    msg.distortion_model = "plumb_bob"
    msg.d = [0.0] * 5
    msg.k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    msg.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    msg.p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return msg


def depth_image(metres: npt.NDArray[np.float32], stamp: Time, frame_id: str) -> Image:
    """32FC1 depth in metres (REP 118)."""
    height, width = metres.shape
    msg = Image(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=height,
        width=width,
        encoding="32FC1",
        step=width * 4,
    )
    msg.data = np.ascontiguousarray(metres, np.float32).tobytes()
    return msg
