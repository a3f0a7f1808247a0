"""Supervision alarms (issue 35): what a motion server reports when someone other than the
brain reaches for the robot's controls, and the plain words the robot says about it.

A motion server's ``supervise`` answer carries ``alarms``: ``[{"code", "detail", "at"}]``
(``FOREIGN_HOLDER``: another holder renewed the lease; ``LOCK_TOPIC_SHARED``: a second
publisher on its lock topic; ``POSE_TOPIC_SHARED`` / ``MAP_TOPIC_SHARED``: a second publisher on
``/amcl_pose`` / ``/map``; ``FOREIGN_GOAL_CLIENT``: a drive goal from another client). While one
is active the server refuses motion and locks; the brain latches its software stop at once
(``MotionSupervisor``) and tells the operator once per alarm, in words without codes. A latched
renewal acknowledges an alarm whose condition is gone; only the operator's Clear stop lifts the
latch. ``not_permitted`` (the server refuses the brain's own lease) is a misconfiguration:
logged and told once, not latched (the server refuses motion without a lease anyway).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import structlog

from robot_voice_chat.robot_words import service_name

logger = structlog.get_logger(__name__)

NOT_PERMITTED = "not_permitted"
BY_SUPERVISION = "the robot's supervision"
"""Who latched the stop for an alarm (the latch's ``by``)."""

# what another program did, per alarm code: "Another program is publishing on my motion lock."
_WHAT: dict[str, str] = {
    "FOREIGN_HOLDER": "Another program tried to take over my safety lease on my {part}.",
    "LOCK_TOPIC_SHARED": "Another program is publishing on the motion lock of my {part}.",
    "POSE_TOPIC_SHARED": "Another program is publishing a position for me, so where I think "
    "I am may be wrong.",
    "MAP_TOPIC_SHARED": "Another program is publishing a map for me, so the map I drive by "
    "may be wrong.",
    "FOREIGN_GOAL_CLIENT": "Another program sent a drive goal straight to my base.",
}
# the same, short, for the latch's reason (the banner and "The robot is stopped: ...")
_REASON: dict[str, str] = {
    "FOREIGN_HOLDER": "another program tried to take over the safety lease on my {part}",
    "LOCK_TOPIC_SHARED": "another program is publishing on the motion lock of my {part}",
    "POSE_TOPIC_SHARED": "another program is publishing a position for me",
    "MAP_TOPIC_SHARED": "another program is publishing a map for me",
    "FOREIGN_GOAL_CLIENT": "another program sent a drive goal straight to my base",
}
_MOVES = frozenset({"FOREIGN_HOLDER", "LOCK_TOPIC_SHARED", "FOREIGN_GOAL_CLIENT"})


@dataclass(frozen=True)
class SupervisionAlarm:
    """One alarm a motion server reported in its ``supervise`` answer."""

    server: str
    code: str
    detail: str
    at: float  # epoch seconds the server raised it

    @property
    def key(self) -> tuple[str, str, float]:
        return (self.server, self.code, self.at)

    def as_dict(self) -> dict[str, Any]:
        return {"server": self.server, "code": self.code, "detail": self.detail, "at": self.at}


@dataclass(frozen=True)
class SupervisionNotice:
    """What the supervisor hands the brain's loop: alarms (the latch is already engaged) or a
    server refusing the brain's lease (``not_permitted``)."""

    kind: Literal["alarms", "not_permitted"]
    server: str
    alarms: tuple[SupervisionAlarm, ...] = ()
    reason: str = ""  # the latch's reason (alarms) or the server's detail (not_permitted)


NoticeHandler = Callable[[SupervisionNotice], Awaitable[None]]


def parse_alarms(server: str, answer: dict[str, Any]) -> list[SupervisionAlarm]:
    """The alarms of one ``supervise`` answer (malformed entries become an UNKNOWN alarm:
    an alarm the brain cannot read is still an alarm)."""
    raw = answer.get("alarms")
    if not isinstance(raw, list):
        return []
    alarms = []
    for item in raw:
        if not isinstance(item, dict):
            item = {}
        code, detail, at = item.get("code"), item.get("detail"), item.get("at")
        alarms.append(
            SupervisionAlarm(
                server=server,
                code=code if isinstance(code, str) and code else "UNKNOWN",
                detail=detail if isinstance(detail, str) else "",
                at=float(at) if isinstance(at, int | float) else 0.0,
            )
        )
    return alarms


def _part(server: str) -> str:
    return service_name(server)


def alarm_reason(alarms: list[SupervisionAlarm] | tuple[SupervisionAlarm, ...]) -> str:
    """The latch's reason: plain words, at most 200 characters, no codes."""
    parts: list[str] = []
    for alarm in alarms:
        text = _REASON.get(alarm.code, "my {part} reported a safety alarm").format(
            part=_part(alarm.server)
        )
        if text not in parts:
            parts.append(text)
    reason = "; ".join(parts) or "a motion server reported a safety alarm"
    return reason if len(reason) <= 200 else reason[:197] + "..."


def alarm_told(alarms: list[SupervisionAlarm] | tuple[SupervisionAlarm, ...]) -> str:
    """What the operator is told, once: why the robot stopped and what to do."""
    moves = any(a.code in _MOVES for a in alarms)
    opening = (
        "Someone else tried to move me, so I stopped."
        if moves
        else "Another program is interfering with how I find my way, so I stopped."
    )
    said: list[str] = []
    for alarm in alarms:
        what = _WHAT.get(alarm.code)
        text = (
            what.format(part=_part(alarm.server))
            if what is not None
            else f"My {_part(alarm.server)} reported a safety alarm."
        )
        if text not in said:
            said.append(text)
    return " ".join([opening, *said, "Check the robot's computer, then clear the stop."])


def not_permitted_told(server: str) -> str:
    return (
        f"My {_part(server)} refuses my safety lease, so it will not move. The credential I "
        "use for it is not the one it accepts: the robot's settings need checking."
    )


@dataclass
class AlarmAnnouncer:
    """The brain's side of a notice: stop everything (the software stop, the mission paused,
    motion tasks cancelled) and tell the operator once per alarm; a refused lease is told
    as it comes (the supervisor sends it once per stretch of refusals)."""

    stop: Callable[[str], Awaitable[object]]  # latch + halt, with the latch's reason
    tell: Callable[[str], Awaitable[None]]  # said and shown as the robot's words
    told: set[tuple[str, str, float]] = field(default_factory=set)

    async def __call__(self, notice: SupervisionNotice) -> None:
        if notice.kind == NOT_PERMITTED:
            await self.tell(not_permitted_told(notice.server))
            return
        await self.stop(notice.reason)
        new = [a for a in notice.alarms if a.key not in self.told]
        if not new:
            return
        self.told.update(a.key for a in new)
        logger.warning(
            "supervision_alarm_told",
            server=notice.server,
            codes=[a.code for a in new],
        )
        await self.tell(alarm_told(new))
