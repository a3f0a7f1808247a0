"""The site map format and the robot's pose, shared by robot-sim and the navigation server
(neither imports the other)."""

from robot_site_map.pose import Pose
from robot_site_map.site_map import (
    FailureSpec,
    Location,
    MapError,
    NavMap,
    load_map,
    normalize_name,
    parse_map,
)

__all__ = [
    "FailureSpec",
    "Location",
    "MapError",
    "NavMap",
    "Pose",
    "load_map",
    "normalize_name",
    "parse_map",
]
