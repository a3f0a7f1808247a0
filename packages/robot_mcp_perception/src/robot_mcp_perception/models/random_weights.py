"""Random-weight checkpoints built by the model libraries' own builders (tests, benchmarks).

Quality needs real weights; API, shapes, loading and speed do not (ARCHITECTURE §6c). Each
function builds a model with the library's own builder or config, with random weights, and
writes it where the adapter loads it from — the adapters then load it through their normal,
real path:

- :func:`sam_checkpoint`: ultralytics' SAM 2.1 / SAM 3 builders (only their weight loading is
  bypassed while building), saved as the state dict ultralytics' loader reads back;
- :func:`owlv2_folder`: a small ``Owlv2Config`` model, a CLIP tokenizer over the byte-level
  alphabet of ``tokenizers`` and the PIL image processor, written by ``save_pretrained``.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path
from typing import Any
from unittest import mock

from robot_mcp_perception.models import _torch_env

SAM_BUILDERS = {
    "sam2.1_t.pt": ("ultralytics.models.sam.build", "build_sam2_t"),
    "sam2.1_b.pt": ("ultralytics.models.sam.build", "build_sam2_b"),
    "sam3.pt": ("ultralytics.models.sam.build_sam3", "build_interactive_sam3"),
}


def sam_checkpoint(directory: Path, name: str = "sam2.1_t.pt", seed: int = 0) -> Path:
    """A random-weight SAM checkpoint named ``name`` (a key of :data:`SAM_BUILDERS`)."""
    _torch_env.prepare()
    torch = importlib.import_module("torch")
    module_name, builder_name = SAM_BUILDERS[name]
    module = importlib.import_module(module_name)
    path = Path(directory) / name
    torch.manual_seed(seed)

    def no_weights(model: Any, *args: Any, **kwargs: Any) -> Any:
        return model

    with mock.patch.object(module, "_load_checkpoint", no_weights):
        model = getattr(module, builder_name)(str(path))
    state = model.state_dict()
    if name.startswith("sam3"):  # the loader reads the interactive model's keys as tracker.*
        state = {f"tracker.{key}": value for key, value in state.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(state, path)
    return path


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
