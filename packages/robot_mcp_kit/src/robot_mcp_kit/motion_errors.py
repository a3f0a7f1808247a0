"""What a motion server's domain says of its failures, in the kit's shapes: the refusals of its
service (``MotionError``, the tools' guard turns them into tool errors), a goal the robot did not
take (``UnavailableError``, raised by a port's adapter), and the named failures of its
action's error codes (``NamedFailure``, rendered in the server's README)."""

from __future__ import annotations

from dataclasses import dataclass


class MotionError(Exception):
    """A request a motion service refuses; ``code`` is stable, ``detail`` is for humans/LLMs.
    The tools' guard (``motion_tools.guard``) turns it into a tool error."""

    code = "MOTION_ERROR"

    def __init__(self, detail: str, code: str | None = None) -> None:
        super().__init__(detail)
        self.detail = detail
        if code is not None:
            self.code = code


class UnknownTaskError(MotionError):
    """No such task on this server (it may predate a restart)."""

    code = "UNKNOWN_TASK"


class UnavailableError(RuntimeError):
    """What moves the robot is absent or refused the goal: the goal is not running."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail


@dataclass(frozen=True)
class NamedFailure:
    """An action's error code as the planner reads it: a stable ``code``, ``what`` happened,
    whether retrying may help, and what to try."""

    code: str
    what: str
    recoverable: bool
    suggestions: tuple[str, ...]


def by_code(*failures: NamedFailure) -> dict[str, NamedFailure]:
    """The named failures of an action, by their code."""
    return {failure.code: failure for failure in failures}
