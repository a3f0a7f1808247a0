"""Owlv2Grounder: OWLv2 through Hugging Face ``transformers`` (Apache-2.0; the ``[hf]`` extra)
— the on-board open-vocabulary detector that works offline (:mod:`.open_vocabulary` says
what it answers).

Every part loads from one local folder named in config (``weights`` / ``GROUNDER_WEIGHTS``),
as ``save_pretrained`` writes it: ``config.json`` + ``model.safetensors`` (the image and
text encoders and the box heads), the tokenizer (``tokenizer.json`` or ``vocab.json`` +
``merges.txt``) and the image processor (``preprocessor_config.json`` or
``processor_config.json``). Loading uses ``local_files_only`` with the hub offline
(:mod:`._torch_env`): nothing is fetched at run time. A missing folder or file is a
start-up error naming the file and the setting.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_mcp_perception.models import _hf
from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models.base import Image, ModelError
from robot_mcp_perception.models.open_vocabulary import Detection, OpenVocabularyGrounder

SETTING = "GROUNDER_WEIGHTS (the detector's `weights` setting)"
REQUIRED = {
    "model config": ("config.json",),
    "model weights": ("model.safetensors", "pytorch_model.bin"),
    "tokenizer": ("tokenizer.json", "vocab.json"),
    "image processor settings": ("preprocessor_config.json", "processor_config.json"),
}


def checked_model_dir(path: str, setting: str = SETTING) -> Path:
    """The local detector folder; a clear error naming the setting and any missing file."""
    return _hf.checked_model_dir(path, setting, REQUIRED, "detector folder")


class Owlv2Grounder(OpenVocabularyGrounder):
    def __init__(
        self,
        weights: str,
        device: str = "cpu",
        confidence: float = 0.2,
        classes: list[str] | tuple[str, ...] | None = None,
        max_targets: int = 20,
    ) -> None:
        folder = checked_model_dir(weights)
        transformers = _hf.import_transformers()
        import torch

        super().__init__(classes, "owlv2")
        self.weights = str(folder)
        self.device = device
        self.confidence = confidence
        self.max_targets = max_targets
        self._torch = torch

        def load() -> tuple[Any, Any]:
            processor = transformers.Owlv2Processor.from_pretrained(folder, local_files_only=True)
            model = transformers.Owlv2ForObjectDetection.from_pretrained(
                folder, local_files_only=True
            )
            return processor, model.to(device).eval()

        try:
            self._processor, self._model = self._pool.submit(load).result()
        except Exception as exc:  # the library boundary: any load failure
            self._pool.shutdown(wait=False)
            raise ModelError(f"could not load the OWLv2 detector from {folder}: {exc}") from exc

    def _detect(self, image: Image, vocabulary: list[str]) -> list[Detection]:
        height, width = check_image(image)
        inputs = self._processor(text=[vocabulary], images=image, return_tensors="pt")
        inputs = {k: v.to(self.device) for k, v in inputs.items()}
        with self._torch.inference_mode():
            outputs = self._model(**inputs)
        found = self._processor.post_process_grounded_object_detection(
            outputs, threshold=self.confidence, target_sizes=[(height, width)]
        )[0]
        boxes = found["boxes"].float().cpu().numpy()
        scores = found["scores"].float().cpu().numpy()
        labels = found["labels"].cpu().numpy()
        order = np.argsort(-scores)[: self.max_targets]
        detections = []
        for i in order:
            x0, y0, x1, y1 = (float(v) for v in boxes[i])
            box = (
                max(0, min(width, round(x0))),
                max(0, min(height, round(y0))),
                max(0, min(width, round(x1))),
                max(0, min(height, round(y1))),
            )
            if box[2] > box[0] and box[3] > box[1]:
                detections.append((box, float(scores[i]), int(labels[i])))
        return detections
