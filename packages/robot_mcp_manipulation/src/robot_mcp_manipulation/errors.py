"""Domain errors of the manipulation service; the MCP edge turns them into tool errors."""

from __future__ import annotations


class ManipulationError(Exception):
    """A request the manipulator refuses; ``code`` is stable, ``detail`` is for humans/LLMs."""

    code = "MANIPULATION_ERROR"

    def __init__(self, detail: str, code: str | None = None) -> None:
        super().__init__(detail)
        self.detail = detail
        if code is not None:
            self.code = code


class ManipulationBusyError(ManipulationError):
    code = "MANIPULATION_BUSY"


class UnknownTaskError(ManipulationError):
    code = "UNKNOWN_TASK"


class ArmUnavailableManipulationError(ManipulationError):
    """The arm's action server is absent or refused the goal; nothing moved."""

    code = "ARM_UNAVAILABLE"


class InvalidDetectionError(ManipulationError):
    """The mask_ref given is not a detection reference (no topic, no stamp)."""

    code = "INVALID_DETECTION"
