"""HfSamSegmenter: SAM 2.1 / SAM 3 through Hugging Face ``transformers`` (Apache-2.0; the
``[hf]`` extra) — the permissive alternative to :class:`.sam.SamSegmenter` (ultralytics,
AGPL-3.0) behind the same port, with the same settings (:mod:`._sam_settings`).

Everything loads from one local folder named in config (``checkpoint`` / ``SAM_CHECKPOINT``),
as ``save_pretrained`` writes it: ``config.json`` + ``model.safetensors`` and the processor
settings (``processor_config.json`` or ``preprocessor_config.json``). Loading uses
``local_files_only`` with the hub offline (:mod:`._torch_env`): nothing is fetched at run
time; a missing folder or file is a start-up error naming the file and the setting. The
folder's ``model_type`` picks the model: ``sam2`` (SAM 2 / 2.1, ``Sam2Model``) or
``sam3_tracker`` (SAM 3's promptable tracker, ``Sam3TrackerModel``; save it from the
``facebook/sam3`` checkpoint with ``Sam3TrackerModel`` / ``Sam3TrackerProcessor``).

One image encode per frame, as in the ultralytics adapter: ``get_image_embeddings`` runs the
encoder once and is kept, keyed by a digest of the pixels; each call then runs the prompt
decoder once for all its boxes and once for all its point-only prompts (the processor pads
shorter point lists with its "padding point" label), single-mask output.

``imgsz``: ``null`` is the size the folder's config names (SAM 2: 1024, SAM 3: 1008); another
size (a multiple of 32 for SAM 2's Hiera, of 14 for SAM 3's ViT) rewrites the config's sizes
before loading (the encoders take any size: SAM 2's Hiera interpolates its position
embedding, SAM 3's ViT tiles it) — the weights are the same.
"""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from robot_mcp_perception.models import _hf, _sam_settings
from robot_mcp_perception.models._checks import check_image, check_points, clip_box
from robot_mcp_perception.models._sam_settings import Precision
from robot_mcp_perception.models._ultralytics import frame_key, to_numpy
from robot_mcp_perception.models.base import (
    Box,
    CostClass,
    Image,
    Mask,
    ModelError,
    ModelUnavailableError,
    Point,
    Segmenter,
    SegmentPrompt,
)

SETTING = "segmenter.checkpoint / SAM_CHECKPOINT"
REQUIRED = {
    "model config": ("config.json",),
    "model weights": ("model.safetensors", "pytorch_model.bin"),
    "processor settings": ("processor_config.json", "preprocessor_config.json"),
}
FAMILIES: dict[str, tuple[str, str, int]] = {
    # model_type: (model class, processor class, input size stride: Hiera's 32, ViT's 14)
    "sam2": ("Sam2Model", "Sam2Processor", 32),
    "sam3_tracker": ("Sam3TrackerModel", "Sam3TrackerProcessor", 14),
}
FEATURE_SCALES = {"sam2": (4, 8, 16), "sam3_tracker": (3.5, 7, 14)}
"""Encoder input pixels per feature-map cell at each of the three levels the decoder reads."""


def model_type(folder: Path) -> str:
    """The folder's ``model_type``; only the families above are served."""
    try:
        kind = str(json.loads((folder / "config.json").read_text()).get("model_type", ""))
    except (OSError, ValueError) as exc:
        raise ModelUnavailableError(f"cannot read {folder / 'config.json'}: {exc}") from exc
    if kind not in FAMILIES:
        raise ModelUnavailableError(
            f"{folder} (set by {SETTING}) holds a {kind or 'unknown'!r} model; segmenter=hf_sam "
            f"serves {' and '.join(FAMILIES)} folders (for facebook/sam3 save its tracker: "
            "Sam3TrackerModel / Sam3TrackerProcessor .from_pretrained(...).save_pretrained(dir))"
        )
    return kind


class HfSamSegmenter(Segmenter):
    cost_class: CostClass = "local"

    def __init__(
        self,
        checkpoint: str,
        device: str = "cuda",
        imgsz: int | None = None,
        precision: Precision = "auto",
        tf32: bool = True,
    ) -> None:
        folder = _hf.checked_model_dir(checkpoint, SETTING, REQUIRED, "SAM model folder")
        self.family = model_type(folder)
        self.precision: Precision = _sam_settings.resolved_precision(precision, device)
        transformers = _hf.import_transformers()
        import torch

        self._torch = torch
        self.tf32 = _sam_settings.enable_tf32(tf32, device)
        self.checkpoint = str(folder)
        self.device = device
        model_class, processor_class, stride = FAMILIES[self.family]
        config = transformers.AutoConfig.from_pretrained(folder, local_files_only=True)
        native = _config_size(config)
        self.imgsz = _sam_settings.checked_imgsz(imgsz, native, stride, folder.name)
        self._encoded: tuple[bytes, Any] | None = None  # (frame_key, embeddings)
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hf_sam")

        def load() -> tuple[Any, Any]:
            if self.imgsz != native:
                _resize_config(config, self.family, self.imgsz)
            model = getattr(transformers, model_class).from_pretrained(
                folder, config=config, local_files_only=True
            )
            processor = getattr(transformers, processor_class).from_pretrained(
                folder, local_files_only=True
            )
            if self.imgsz != native:
                _resize_processor(processor, self.family, self.imgsz)
            return processor, model.to(device).eval()

        try:
            self._processor, self._model = self._pool.submit(load).result()
        except Exception as exc:  # the library boundary: any load failure
            self._pool.shutdown(wait=False)
            raise ModelError(f"could not load the SAM model from {folder}: {exc}") from exc

    def close(self) -> None:
        self._pool.shutdown(wait=True)

    def segment_box(self, image: Image, box: Box) -> Mask:
        height, width = check_image(image)
        return self.segment_many(image, [SegmentPrompt(box=clip_box(box, width, height))])[0]

    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        height, width = check_image(image)
        return self.segment_many(
            image, [SegmentPrompt(points=check_points(points, width, height))]
        )[0]

    def segment_many(self, image: Image, prompts: list[SegmentPrompt]) -> list[Mask]:
        height, width = check_image(image)
        if not prompts:
            return []
        batches = _sam_settings.prompt_batches(prompts, width, height)
        decodes: list[tuple[list[int], dict[str, Any]]] = [
            (batches.boxed, {"input_boxes": [[list(box) for box in batches.boxes]]}),
            (
                batches.pointed,
                {
                    "input_points": [batches.points],
                    "input_labels": [[[1] * len(pts) for pts in batches.points]],
                },
            ),
        ]

        def run() -> list[Mask]:
            masks: dict[int, Mask] = {}
            with self._torch.inference_mode(), _sam_settings.autocast(self.precision, self.device):
                embeddings = self._encode(image)
                for indices, prompt in decodes:
                    if indices:  # the prompt decoder only: the embedding is the frame's
                        found = self._decode(embeddings, prompt, (height, width))
                        masks.update(zip(indices, found, strict=True))
            return [masks[i] for i in range(len(prompts))]

        try:
            return self._pool.submit(run).result()
        except Exception as exc:  # the library boundary (CUDA OOM, bad prompt, …)
            raise ModelError(f"SAM prediction failed: {exc}") from exc

    def _encode(self, image: Image) -> Any:
        """The frame's image embeddings: kept from the last call on the same pixels, else the
        encoder runs. Worker thread only, so the key and the embeddings change together."""
        key = frame_key(image)
        if self._encoded is not None and self._encoded[0] == key:
            return self._encoded[1]
        self._encoded = None  # a failed encode leaves no embedding to trust
        pixels = self._processor(images=image, return_tensors="pt")["pixel_values"]
        embeddings = self._model.get_image_embeddings(pixels.to(self.device))
        self._encoded = (key, embeddings)
        return embeddings

    def _decode(
        self, embeddings: Any, prompt: dict[str, Any], shape: tuple[int, int]
    ) -> list[Mask]:
        """One decoder pass for a batch of prompts: one full-frame mask per prompt."""
        inputs = self._processor(original_sizes=[list(shape)], return_tensors="pt", **prompt)
        tensors = {k: v.to(self.device) for k, v in inputs.items() if k != "original_sizes"}
        outputs = self._model(image_embeddings=embeddings, multimask_output=False, **tensors)
        logits = outputs.pred_masks.float().cpu()
        masks = self._processor.post_process_masks(logits, [list(shape)], binarize=True)[0]
        return [np.asarray(m, dtype=bool) for m in to_numpy(masks[:, 0])]


def _config_size(config: Any) -> int:
    return int(config.prompt_encoder_config.image_size)


def _resize_config(config: Any, family: str, size: int) -> None:
    """Point every size the model reads at ``size`` (encoder input, feature maps, prompts)."""
    backbone = config.vision_config.backbone_config
    backbone.image_size = [size, size] if isinstance(backbone.image_size, list) else size
    config.vision_config.backbone_feature_sizes = [
        [int(size / scale)] * 2 for scale in FEATURE_SCALES[family]
    ]
    config.prompt_encoder_config.image_size = size


def _resize_processor(processor: Any, family: str, size: int) -> None:
    finest = int(size / FEATURE_SCALES[family][0])
    processor.image_processor.size = {"height": size, "width": size}
    processor.image_processor.mask_size = {"height": finest, "width": finest}
    processor.target_size = size
