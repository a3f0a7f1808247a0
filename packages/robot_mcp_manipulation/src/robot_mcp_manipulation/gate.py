"""The one seam where motion is admitted: before a pick or place goal is sent (and again once
the arm took it), the manipulator asks its :class:`MotionGate` whether motion may start now.

A gate answers ``None`` (go ahead) or a refusal with a stable ``code`` and a ``detail``
(e.g. ``SAFETY_STOP_LATCHED``). ``robot_mcp_kit.supervision.Supervision`` (the brain's lease
and latch, issue 27) has exactly this ``refusal()`` shape, so supervising this server is:
build one in the composition root, pass it as the gate, serve its ``supervise`` tool and call
``Manipulator.stop`` when it lapses or latches. ``OpenGate`` admits everything (the default).
"""

from __future__ import annotations

from typing import Protocol


class GateRefusal(Protocol):
    @property
    def code(self) -> str: ...

    @property
    def detail(self) -> str: ...


class MotionGate(Protocol):
    def refusal(self) -> GateRefusal | None:
        """Why motion must not start now, or None."""


class OpenGate:
    """Admits every motion (no supervisor configured)."""

    def refusal(self) -> GateRefusal | None:
        return None
