"""Domain errors of the navigation service; the MCP edge turns them into tool errors."""

from __future__ import annotations

from robot_mcp_kit.motion_errors import MotionError
from robot_mcp_kit.motion_errors import UnknownTaskError as UnknownTaskError


class NavigationError(MotionError):
    """A request the navigator refuses; ``code`` is stable, ``detail`` is for humans/LLMs."""

    code = "NAVIGATION_ERROR"


class UnknownLocationError(NavigationError):
    code = "UNKNOWN_LOCATION"


class NavigationBusyError(NavigationError):
    code = "NAVIGATION_BUSY"


class BaseUnavailableNavigationError(NavigationError):
    """The base's driver (e.g. Nav2) is absent or refused the goal; nothing moved."""

    code = "BASE_UNAVAILABLE"


class MotionRefusedError(NavigationError):
    """Supervision refuses motion now: ``SAFETY_STOP_LATCHED`` (the brain's software stop is
    latched) or ``NOT_SUPERVISED`` (no fresh lease from a supervising brain)."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(detail, code)
