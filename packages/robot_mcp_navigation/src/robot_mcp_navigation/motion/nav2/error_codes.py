"""Nav2's numeric error codes (navigation2 1.4.2) → the named failures the planner reads.

Nav2's bt_navigator ends an aborted NavigateToPose with the error code of the behaviour-tree
node that failed: its own codes (9000-9003) or the planner's (ComputePathToPose 200-208), the
controller's (FollowPath 100-107), the smoother's (500-505) and the recovery behaviours'
(Spin 700-703, BackUp 710-714, DriveOnHeading 720-724, AssistedTeleop 730-732, Wait 740-741).
The README ("Nav2 error codes") renders this table; a test keeps the two equal.
"""

from __future__ import annotations

from robot_mcp_kit.motion_errors import NamedFailure, by_code
from robot_mcp_navigation.motion.base import DriveFailure

_RETRY = "call navigate_to again once; if it fails again, ask an operator"
_OPERATOR = "ask an operator to check the robot's Nav2 (its logs name the problem)"

FAILURES = by_code(
    NamedFailure(
        "NO_PATH",
        "Nav2 found no path to the destination (the way may be blocked, e.g. a closed door)",
        True,
        (
            "try a detour: navigate_to a location on another route, then to the destination",
            "ask someone to open or clear the way, then call navigate_to again",
        ),
    ),
    NamedFailure(
        "ROBOT_STUCK",
        "the robot could not make progress along its path (an obstacle in the way?)",
        True,
        (
            "ask someone to clear the way, then call navigate_to again",
            "try a detour: navigate_to a location on another route, then to the destination",
        ),
    ),
    NamedFailure(
        "OBSTACLE_AHEAD",
        "a recovery manoeuvre stopped because of an obstacle close to the robot",
        True,
        ("ask someone to clear the space around the robot, then call navigate_to again",),
    ),
    NamedFailure(
        "GOAL_BLOCKED",
        "the destination itself is occupied on Nav2's costmap",
        True,
        (
            "ask someone to clear the destination, then call navigate_to again",
            "navigate_to a nearby location instead",
        ),
    ),
    NamedFailure(
        "START_BLOCKED",
        "the robot's own position is occupied on Nav2's costmap (boxed in?)",
        True,
        ("ask someone to clear the space around the robot, then call navigate_to again",),
    ),
    NamedFailure(
        "NAVIGATION_TIMEOUT",
        "Nav2 gave up because the drive (or a step of it) took too long",
        True,
        ("check for obstacles, then call navigate_to again",),
    ),
    NamedFailure(
        "PLANNER_FAILED",
        "Nav2's planner or path smoother failed",
        True,
        (_RETRY,),
    ),
    NamedFailure(
        "CONTROLLER_FAILED",
        "Nav2's controller failed while following the path",
        True,
        (_RETRY,),
    ),
    NamedFailure(
        "RECOVERY_FAILED",
        "a Nav2 recovery behaviour failed",
        True,
        (_RETRY,),
    ),
    NamedFailure(
        "NAVIGATION_ABORTED",
        "Nav2 aborted the drive without naming a cause",
        True,
        (_RETRY,),
    ),
    NamedFailure(
        "LOCALIZATION_LOST",
        "Nav2 does not know where the robot is (no map→base transform, or outside the map)",
        False,
        ("ask an operator to re-localize the robot (set its initial pose), then retry",),
    ),
    NamedFailure(
        "GOAL_OUTSIDE_MAP",
        "the destination's pose is outside Nav2's map (the map file and the robot's map disagree)",
        False,
        ("ask an operator to fix the location's x/y in the navigation map file",),
    ),
    NamedFailure(
        "NAV2_CONFIG_ERROR",
        "Nav2 is misconfigured (behaviour tree, planner or controller plugin not loaded)",
        False,
        (_OPERATOR,),
    ),
    NamedFailure(
        "NAV2_ERROR",
        "Nav2 aborted the drive with an error code this server does not know",
        False,
        (_OPERATOR,),
    ),
)

CODES: dict[int, str] = {
    0: "NAVIGATION_ABORTED",  # ABORTED with NONE: Nav2 set no code
    # NavigateToPose (bt_navigator)
    9000: "NAVIGATION_ABORTED",  # UNKNOWN
    9001: "NAV2_CONFIG_ERROR",  # FAILED_TO_LOAD_BEHAVIOR_TREE
    9002: "LOCALIZATION_LOST",  # TF_ERROR
    9003: "NAVIGATION_TIMEOUT",  # TIMEOUT
    # FollowPath (controller server)
    100: "CONTROLLER_FAILED",  # UNKNOWN
    101: "NAV2_CONFIG_ERROR",  # INVALID_CONTROLLER
    102: "LOCALIZATION_LOST",  # TF_ERROR
    103: "NO_PATH",  # INVALID_PATH
    104: "ROBOT_STUCK",  # PATIENCE_EXCEEDED
    105: "ROBOT_STUCK",  # FAILED_TO_MAKE_PROGRESS
    106: "ROBOT_STUCK",  # NO_VALID_CONTROL
    107: "NAVIGATION_TIMEOUT",  # CONTROLLER_TIMED_OUT
    # ComputePathToPose (planner server)
    200: "PLANNER_FAILED",  # UNKNOWN
    201: "NAV2_CONFIG_ERROR",  # INVALID_PLANNER
    202: "LOCALIZATION_LOST",  # TF_ERROR
    203: "LOCALIZATION_LOST",  # START_OUTSIDE_MAP
    204: "GOAL_OUTSIDE_MAP",  # GOAL_OUTSIDE_MAP
    205: "START_BLOCKED",  # START_OCCUPIED
    206: "GOAL_BLOCKED",  # GOAL_OCCUPIED
    207: "PLANNER_FAILED",  # TIMEOUT
    208: "NO_PATH",  # NO_VALID_PATH
    # SmoothPath (smoother server)
    500: "PLANNER_FAILED",  # UNKNOWN
    501: "NAV2_CONFIG_ERROR",  # INVALID_SMOOTHER
    502: "PLANNER_FAILED",  # TIMEOUT
    503: "NO_PATH",  # SMOOTHED_PATH_IN_COLLISION
    504: "PLANNER_FAILED",  # FAILED_TO_SMOOTH_PATH
    505: "NO_PATH",  # INVALID_PATH
    # Spin, BackUp, DriveOnHeading, AssistedTeleop, Wait (behavior server)
    700: "RECOVERY_FAILED",  # Spin UNKNOWN
    701: "RECOVERY_FAILED",  # Spin TIMEOUT
    702: "LOCALIZATION_LOST",  # Spin TF_ERROR
    703: "OBSTACLE_AHEAD",  # Spin COLLISION_AHEAD
    710: "RECOVERY_FAILED",  # BackUp UNKNOWN
    711: "RECOVERY_FAILED",  # BackUp TIMEOUT
    712: "LOCALIZATION_LOST",  # BackUp TF_ERROR
    713: "NAV2_CONFIG_ERROR",  # BackUp INVALID_INPUT
    714: "OBSTACLE_AHEAD",  # BackUp COLLISION_AHEAD
    720: "RECOVERY_FAILED",  # DriveOnHeading UNKNOWN
    721: "RECOVERY_FAILED",  # DriveOnHeading TIMEOUT
    722: "LOCALIZATION_LOST",  # DriveOnHeading TF_ERROR
    723: "OBSTACLE_AHEAD",  # DriveOnHeading COLLISION_AHEAD
    724: "NAV2_CONFIG_ERROR",  # DriveOnHeading INVALID_INPUT
    730: "RECOVERY_FAILED",  # AssistedTeleop UNKNOWN
    731: "RECOVERY_FAILED",  # AssistedTeleop TIMEOUT
    732: "LOCALIZATION_LOST",  # AssistedTeleop TF_ERROR
    740: "RECOVERY_FAILED",  # Wait UNKNOWN
    741: "RECOVERY_FAILED",  # Wait TIMEOUT
}


def named_failure(error_code: int) -> NamedFailure:
    return FAILURES[CODES.get(error_code, "NAV2_ERROR")]


def drive_failure(
    error_code: int, error_msg: str, destination: str, site_hints: tuple[str, ...] = ()
) -> DriveFailure:
    """The DriveFailure for an ABORTED goal: the named code, Nav2's own words, and what to
    try (``site_hints`` — the map's suggestions for this destination — first)."""
    named = named_failure(error_code)
    said = error_msg.strip() or "no message"
    message = f"{named.what} on the way to {destination} (Nav2 error {error_code}: {said})"
    hints = site_hints if named.recoverable else ()  # a detour cannot fix a lost robot
    suggestions = list(dict.fromkeys([*hints, *named.suggestions]))
    return DriveFailure(named.code, message, named.recoverable, suggestions)
