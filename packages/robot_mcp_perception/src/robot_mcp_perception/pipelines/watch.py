"""The watch pipeline: a boolean output behind a cheap frame-difference gate (spec 000 §5, §8).

:class:`FrameDiffGate` is what the node's engine consults (``watch.gate_threshold``,
``cloud_requires_gate``): the expensive (cloud) stage runs only when the scene changed — an
unchanged frame costs no model call and the previous result is republished (stale, reason
``scene_unchanged``). :func:`watched_value` is applied by the router to every run of a
watcher skill, so its watched output is always published as a JSON boolean.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_mcp_perception.models.base import Image, ModelError
from robot_mcp_perception.pipelines.common import SkillModeError, SkillResult
from robot_mcp_perception.prompt_builder import coerce_value
from robot_mcp_perception.skills import Skill


class FrameDiffGate:
    """Passes a frame when it differs enough from the last frame that passed.

    Difference = mean absolute difference of ``thumb_size`` grayscale thumbnails, scaled to
    **0..1** (0 = identical, 1 = black vs white). ``threshold`` is on that scale; the default
    0.02 ignores sensor noise and JPEG artefacts but passes an object appearing, moving or
    disappearing. The first frame (and the first after :meth:`reset`) always passes.
    Comparing with the last *passed* frame (not the previous one) means slow drift still
    passes once it adds up.
    """

    def __init__(self, threshold: float = 0.02, thumb_size: tuple[int, int] = (32, 24)) -> None:
        if not 0.0 <= threshold <= 1.0:
            raise ValueError(f"threshold is a 0..1 mean absolute difference, got {threshold}")
        if thumb_size[0] < 1 or thumb_size[1] < 1:
            raise ValueError(f"thumb_size must be positive, got {thumb_size}")
        self.threshold = threshold
        self.thumb_size = thumb_size
        self.last_difference: float | None = None
        """Difference of the last frame checked (None before the first comparison)."""
        self._reference: npt.NDArray[np.float32] | None = None

    def difference(self, image: Image) -> float:
        """Difference (0..1) of ``image`` to the reference frame; 1.0 when there is none."""
        if self._reference is None:
            return 1.0
        return float(np.mean(np.abs(self._thumb(image) - self._reference)))

    def passes(self, image: Image) -> bool:
        thumb = self._thumb(image)
        if self._reference is None:
            self.last_difference = None
            self._reference = thumb
            return True
        self.last_difference = float(np.mean(np.abs(thumb - self._reference)))
        if self.last_difference > self.threshold:
            self._reference = thumb
            return True
        return False

    def reset(self) -> None:
        self._reference = None
        self.last_difference = None

    def _thumb(self, image: Image) -> npt.NDArray[np.float32]:
        if image.ndim != 3 or image.shape[2] != 3 or image.size == 0:
            raise ValueError(f"image must be RGB (H, W, 3), got shape {image.shape}")
        gray = cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY)
        small = cv2.resize(gray, self.thumb_size, interpolation=cv2.INTER_AREA)
        return np.asarray(small, np.float32) / 255.0


def watched_value(skill: Skill, result: SkillResult) -> bool:
    """The watched boolean of a result (coerced); ModelError when the model did not give it."""
    if skill.watch is None:
        raise SkillModeError(f"skill {skill.name!r} has no watch block")
    name = skill.watch.output
    if name not in result.outputs:
        raise ModelError(f"watched output {name!r} missing from the answer of skill {skill.name!r}")
    try:
        value: Any = coerce_value(result.outputs[name], "boolean")
    except ValueError as exc:
        raise ModelError(f"watched output {name!r} is not a boolean: {exc}") from exc
    return bool(value)
