"""Triggers a caller can attach to navigate_to; each fires once, as a trigger_fired event."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from robot_mcp_navigation.motion.base import DriveProgress


class EtaBelow(BaseModel):
    """Fires once when the estimated time to arrival drops below ``seconds``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    type: Literal["eta_below"] = "eta_below"
    seconds: float = Field(gt=0, description="Fire when the ETA (robot seconds) is below this.")

    def is_met(self, progress: DriveProgress) -> bool:
        return progress.eta_s < self.seconds


class DistanceBelow(BaseModel):
    """Fires once when the remaining distance drops below ``meters``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    type: Literal["distance_below"] = "distance_below"
    meters: float = Field(gt=0, description="Fire when fewer than this many metres remain.")

    def is_met(self, progress: DriveProgress) -> bool:
        return progress.distance_remaining_m < self.meters


Trigger = Annotated[EtaBelow | DistanceBelow, Field(discriminator="type")]
