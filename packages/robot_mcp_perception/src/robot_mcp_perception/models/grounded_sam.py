"""GroundedSamGrounder: YOLO-World through ultralytics (the ``[sam]`` extra) as the local
open-vocabulary detector (:mod:`.open_vocabulary` says what it answers).

**Not offline**: YOLO-World's ``set_classes`` encodes the vocabulary with CLIP, which
ultralytics 8.4 imports from the ``clip`` package (a git URL, not on PyPI) and whose weights
it downloads on first use. Offline this fails; the adapter says so at start-up (it encodes
its configured classes once), naming ``grounder=owlv2`` — OWLv2 through ``transformers``,
whose text encoder and tokenizer load from the same local folder — as the offline choice.
"""

from __future__ import annotations

from typing import Any

import cv2

from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models._ultralytics import checked_weights, import_ultralytics, to_numpy
from robot_mcp_perception.models.base import Image, ModelError, ModelUnavailableError
from robot_mcp_perception.models.open_vocabulary import (
    DEFAULT_CLASSES,
    Detection,
    OpenVocabularyGrounder,
)

__all__ = ["DEFAULT_CLASSES", "GroundedSamGrounder"]
OFFLINE_HINT = (
    "YOLO-World encodes its vocabulary with CLIP, which ultralytics fetches at run time (the "
    "`clip` package from a git URL and its weights); offline, use grounder=owlv2 (OWLv2 "
    "through transformers, every part from a local folder)"
)


class GroundedSamGrounder(OpenVocabularyGrounder):
    def __init__(
        self,
        weights: str,
        device: str = "cpu",
        confidence: float = 0.25,
        classes: list[str] | tuple[str, ...] | None = None,
    ) -> None:
        path = checked_weights(weights, "grounder.weights", "GROUNDER_WEIGHTS")
        ultralytics = import_ultralytics()
        super().__init__(classes, "grounded-sam")
        self.weights = str(path)
        self.device = device
        self.confidence = confidence

        def load() -> Any:
            model = ultralytics.YOLOWorld(self.weights)
            model.set_classes(self.classes)  # the text encoder: fails here when it is absent
            return model

        try:
            self._model = self._pool.submit(load).result()
        except ImportError as exc:  # `clip` (and its weights) cannot be fetched offline
            self._pool.shutdown(wait=False)
            raise ModelUnavailableError(f"{OFFLINE_HINT} ({exc})") from exc
        except Exception as exc:  # the library boundary
            self._pool.shutdown(wait=False)
            raise ModelError(f"could not load detector weights {path}: {exc}") from exc

    def _detect(self, image: Image, vocabulary: list[str]) -> list[Detection]:
        check_image(image)
        self._model.set_classes(vocabulary)
        bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
        results = self._model.predict(bgr, conf=self.confidence, device=self.device, verbose=False)
        if not results:
            return []
        boxes = results[0].boxes
        xyxy, conf, cls = to_numpy(boxes.xyxy), to_numpy(boxes.conf), to_numpy(boxes.cls)
        return [
            ((round(float(a)), round(float(b)), round(float(c)), round(float(d))), float(s), int(k))
            for (a, b, c, d), s, k in zip(xyxy, conf, cls, strict=True)
        ]
