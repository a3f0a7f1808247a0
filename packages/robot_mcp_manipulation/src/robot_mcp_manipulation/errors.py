"""Domain errors of the manipulation service; the MCP edge turns them into tool errors."""

from __future__ import annotations

from robot_mcp_kit.motion_errors import MotionError
from robot_mcp_kit.motion_errors import UnknownTaskError as UnknownTaskError


class ManipulationError(MotionError):
    """A request the manipulator refuses; ``code`` is stable, ``detail`` is for humans/LLMs."""

    code = "MANIPULATION_ERROR"


class ManipulationBusyError(ManipulationError):
    code = "MANIPULATION_BUSY"


class ArmUnavailableManipulationError(ManipulationError):
    """The arm's action server is absent or refused the goal; nothing moved."""

    code = "ARM_UNAVAILABLE"


class InvalidDetectionError(ManipulationError):
    """The mask_ref given is not a detection reference (no topic, no stamp)."""

    code = "INVALID_DETECTION"
