"""Random-weight checkpoints built by the model libraries' own builders (tests, benchmarks).

Quality needs real weights; API, shapes, loading and speed do not (ARCHITECTURE §6c). Each
function builds a model with the library's own builder or config, with random weights, and
writes it where the adapter loads it from — the adapters then load it through their normal,
real path:

- :func:`sam_checkpoint`: ultralytics' SAM 2.1 / SAM 3 builders (their weight loading and
  initialisation bypassed while building, weights filled from a seeded random block), saved
  as the state dict ultralytics' loader reads back;
- :func:`owlv2_folder`: a small ``Owlv2Config`` model, a CLIP tokenizer over the byte-level
  alphabet of ``tokenizers`` and the PIL image processor, written by ``save_pretrained``;
- :func:`hf_sam_folder`: transformers' SAM 2 (``Sam2Config``) or SAM 3 tracker
  (``Sam3TrackerConfig``) with its processor, written by ``save_pretrained`` — the library's
  default configs (SAM 2.1 Hiera-tiny, SAM 3) or, for tests, small ones of the same layout.
"""

from __future__ import annotations

import contextlib
import importlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from unittest import mock

from robot_mcp_perception.models import _torch_env
from robot_mcp_perception.models._ultralytics import restore_pillow

SAM_BUILDERS = {
    "sam2.1_t.pt": ("ultralytics.models.sam.build", "build_sam2_t"),
    "sam2.1_b.pt": ("ultralytics.models.sam.build", "build_sam2_b"),
    "sam3.pt": ("ultralytics.models.sam.build_sam3", "build_interactive_sam3"),
}


def sam_checkpoint(directory: Path, name: str = "sam2.1_t.pt", seed: int = 0) -> Path:
    """A random-weight SAM checkpoint named ``name`` (a key of :data:`SAM_BUILDERS`).

    The builder's own initialisation (truncated-normal and uniform draws over ~470 M weights
    for SAM 3: most of its build time on a CPU) is skipped and the weights are filled from one
    seeded random block instead; the checkpoint is stored in bfloat16 (half the bytes to write
    and read; ultralytics' loader copies it into its fp32 model)."""
    _torch_env.prepare()
    torch = importlib.import_module("torch")
    module_name, builder_name = SAM_BUILDERS[name]
    module = importlib.import_module(module_name)
    restore_pillow()  # importing the builder imported ultralytics
    path = Path(directory) / name

    def no_weights(model: Any, *args: Any, **kwargs: Any) -> Any:
        return model

    with mock.patch.object(module, "_load_checkpoint", no_weights), _no_init(torch):
        model = getattr(module, builder_name)(str(path))
    _fill(torch, model, seed)
    state = {key: value.to(torch.bfloat16) for key, value in model.state_dict().items()}
    if name.startswith("sam3"):  # the loader reads the interactive model's keys as tracker.*
        state = {f"tracker.{key}": value for key, value in state.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(state, path)
    return path


@contextlib.contextmanager
def _no_init(torch: Any) -> Iterator[None]:
    """``torch.nn.init``'s in-place initialisers as no-ops (layers call them through the
    module, so this reaches every ``reset_parameters``)."""

    def keep(tensor: Any, *args: Any, **kwargs: Any) -> Any:
        return tensor

    names = ("uniform_", "normal_", "trunc_normal_", "kaiming_uniform_", "kaiming_normal_",
             "xavier_uniform_", "xavier_normal_", "constant_", "zeros_", "ones_")  # fmt: skip
    with contextlib.ExitStack() as stack:
        for name in names:
            stack.enter_context(mock.patch.object(torch.nn.init, name, keep))
        yield


def _fill(torch: Any, model: Any, seed: int, block_size: int = 1 << 20) -> None:
    """Every parameter from one seeded uniform(-0.05, 0.05) block, repeated."""
    generator = torch.Generator().manual_seed(seed)
    block = torch.empty(block_size).uniform_(-0.05, 0.05, generator=generator)
    with torch.no_grad():
        for parameter in model.parameters():
            flat = parameter.view(-1)
            for start in range(0, flat.numel(), block_size):
                part = flat[start : start + block_size]
                part.copy_(block[: part.numel()])


def owlv2_folder(directory: Path, image_size: int = 64, seed: int = 0) -> Path:
    """A small random-weight OWLv2 model folder (model, tokenizer, processor settings)."""
    _torch_env.prepare()
    torch = importlib.import_module("torch")
    transformers = importlib.import_module("transformers")
    pre_tokenizers = importlib.import_module("tokenizers.pre_tokenizers")
    pil_processor = importlib.import_module(
        "transformers.models.owlv2.image_processing_pil_owlv2"
    ).Owlv2ImageProcessorPil
    folder = Path(directory)
    folder.mkdir(parents=True, exist_ok=True)
    chars = sorted(pre_tokenizers.ByteLevel.alphabet())
    specials = ["<|startoftext|>", "<|endoftext|>"]
    vocab = {token: i for i, token in enumerate([*chars, *(c + "</w>" for c in chars), *specials])}
    tokenizer = transformers.CLIPTokenizer(vocab=vocab, merges=[])
    small = {"hidden_size": 32, "intermediate_size": 64, "num_hidden_layers": 2}
    config = transformers.Owlv2Config(
        text_config={
            **small,
            "num_attention_heads": 2,
            "vocab_size": len(vocab),
            "max_position_embeddings": 16,
            "bos_token_id": vocab[specials[0]],
            "eos_token_id": vocab[specials[1]],
            "pad_token_id": vocab[specials[1]],
        },
        vision_config={
            **small,
            "num_attention_heads": 2,
            "image_size": image_size,
            "patch_size": 16,
        },
        projection_dim=32,
    )
    torch.manual_seed(seed)
    model = transformers.Owlv2ForObjectDetection(config).eval()
    with torch.no_grad():  # boxes near each patch's prior box, not saturated to zero width
        model.box_head.dense2.weight.mul_(0.01)
        model.box_head.dense2.bias.zero_()
    model.save_pretrained(folder)
    image_processor = pil_processor(size={"height": image_size, "width": image_size})
    transformers.Owlv2Processor(
        image_processor=image_processor, tokenizer=tokenizer
    ).save_pretrained(folder)
    (folder / "random_weights.json").write_text(json.dumps({"note": "random weights, tests only"}))
    return folder


def hf_sam_folder(
    directory: Path, family: str = "sam2", small: bool = True, image_size: int | None = None
) -> Path:
    """A random-weight transformers SAM folder: ``family`` ``sam2`` or ``sam3_tracker``.

    ``small``: a few-layer config at ``image_size`` (default 64 for SAM 2, 56 for SAM 3) that
    keeps every part of the layout (multi-level features, prompt encoder, mask decoder) for
    cheap CPU tests; otherwise the library's default config (SAM 2.1 Hiera-tiny at 1024 px,
    SAM 3 at 1008 px)."""
    _torch_env.prepare()
    torch = importlib.import_module("torch")
    transformers = importlib.import_module("transformers")
    folder = Path(directory)
    folder.mkdir(parents=True, exist_ok=True)
    if family == "sam2":
        size = image_size or (64 if small else 1024)
        config = transformers.Sam2Config(**(_small_sam2(size) if small else {}))
        processor = transformers.Sam2Processor(
            image_processor=transformers.Sam2ImageProcessor(
                size={"height": size, "width": size},
                mask_size={"height": size // 4, "width": size // 4},
            )
        )
        model_class = transformers.Sam2Model
    elif family == "sam3_tracker":
        size = image_size or (56 if small else 1008)
        config = transformers.Sam3TrackerConfig(**(_small_sam3(size) if small else {}))
        processor = transformers.Sam3TrackerProcessor(
            image_processor=transformers.Sam3ImageProcessor(
                size={"height": size, "width": size},
                mask_size={"height": 4 * size // 14, "width": 4 * size // 14},
            )
        )
        model_class = transformers.Sam3TrackerModel
    else:
        raise ValueError(f"family must be sam2 or sam3_tracker: {family!r}")
    torch.manual_seed(0)
    model_class(config).eval().save_pretrained(folder)
    processor.save_pretrained(folder)
    return folder


_SMALL_DECODER = {
    "prompt_encoder_config": {"hidden_size": 32},
    "mask_decoder_config": {
        "hidden_size": 32,
        "mlp_dim": 64,
        "num_attention_heads": 2,
        "iou_head_hidden_dim": 32,
    },
}


def _small_sam2(size: int) -> dict[str, Any]:
    """Hiera with one or two blocks per stage (a global-attention block inside a stage, as
    the real configs have it), a narrow FPN and decoder."""
    hiera = {
        "model_type": "sam2_hiera_det_model",
        "hidden_size": 16,
        "embed_dim_per_stage": [16, 32, 64, 128],
        "num_attention_heads_per_stage": [1, 1, 2, 2],
        "blocks_per_stage": [1, 1, 2, 1],
        "global_attention_blocks": [3],
        "window_size_per_stage": [8, 4, 4, 4],
        "image_size": [size, size],
    }
    return {
        "vision_config": {
            "backbone_config": hiera,
            "backbone_channel_list": [128, 64, 32, 16],
            "backbone_feature_sizes": [[size // 4] * 2, [size // 8] * 2, [size // 16] * 2],
            "fpn_hidden_size": 32,
        },
        "prompt_encoder_config": {**_SMALL_DECODER["prompt_encoder_config"], "image_size": size},
        "mask_decoder_config": _SMALL_DECODER["mask_decoder_config"],
    }


def _small_sam3(size: int) -> dict[str, Any]:
    """SAM 3's ViT with two layers (one windowed, one global), a narrow FPN and decoder."""
    grid = size // 14
    vit = {
        "model_type": "sam3_vit_model",
        "hidden_size": 32,
        "intermediate_size": 64,
        "num_hidden_layers": 2,
        "num_attention_heads": 2,
        "image_size": size,
        "patch_size": 14,
        "window_size": 2,
        "global_attn_indexes": [1],
        "pretrain_image_size": 28,
    }
    return {
        "vision_config": {
            "model_type": "sam3_vision_model",
            "backbone_config": vit,
            "fpn_hidden_size": 32,
            "backbone_feature_sizes": [[4 * grid] * 2, [2 * grid] * 2, [grid] * 2],
        },
        "prompt_encoder_config": {**_SMALL_DECODER["prompt_encoder_config"], "image_size": size},
        "mask_decoder_config": _SMALL_DECODER["mask_decoder_config"],
    }
