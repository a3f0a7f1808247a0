#!/usr/bin/env bash
# The model libraries of robot_mcp_perception's [sam] and [hf] extras (ultralytics, timm,
# transformers) and robot_voice_chat's [whisper] extra (faster-whisper; locked versions),
# and torch + torchvision, in the workspace venv: `make test`
# runs every model adapter against the real libraries with random-weight checkpoints on the
# CPU (issue 30). Outside the default sync on purpose (gigabytes no other package needs).
#
# torch + torchvision come from a local package index (TORCH_INDEX, default the CI machine's
# mirror file:///opt/pypi-more/simple, which pip on that machine also uses): its CUDA build
# runs on the CPU, and torchvision's C++ ops load beside it. The CPU-only torch wheel in
# /opt/wheels is not enough: PyPI's torchvision cannot load beside it, and timm (SAM 3's image
# encoder) and transformers' SAM processors need torchvision. Without such an index the
# script skips and the model-library tests skip with a reason; elsewhere use
# `uv sync --extra sam --extra hf` (PyPI's torch) or PyTorch's CPU wheels of torch AND
# torchvision.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export PATH="$HOME/.local/bin:$PATH"

venv=.venv
index=${TORCH_INDEX:-file:///opt/pypi-more/simple}
torch_pin=${TORCH_PIN:-torch==2.14.1 torchvision==0.29.1}
stamp="$venv/.model-libs-$(cat uv.lock "${BASH_SOURCE[0]}" | sha256sum | cut -c1-16)"
[[ -f $stamp ]] && exit 0
if [[ $index == file://* && ! -d ${index#file://} ]]; then
  echo "install-model-libs: no local torch index at $index: skipping the model libraries" \
       "(their tests skip). See packages/robot_mcp_perception/README.md, Model libraries." >&2
  exit 0
fi
started=$SECONDS
requirements=$(mktemp)
trap 'rm -f "$requirements"' EXIT
# The extras' locked pins, less torch/torchvision and the CUDA runtime (they come with torch):
# perception's [sam] and [hf], and the brain's [whisper] (faster-whisper, ctranslate2,
# onnxruntime; its real-library test converts a random-weight model with transformers). The
# environment markers stay: uv leaves out what this platform does not use (pywin32).
{
  uv export --frozen --package robot-mcp-perception --extra sam --extra hf --no-hashes \
    --no-emit-workspace --no-header --no-annotate --format requirements.txt
  uv export --frozen --package robot-voice-chat --extra whisper --no-hashes \
    --no-emit-workspace --no-header --no-annotate --format requirements.txt
} | grep -v -E '^(torch==|torchvision==|triton|nvidia-|cuda-)' | sort -u > "$requirements"
uv pip install --quiet --python "$venv" --no-deps -r "$requirements"
# shellcheck disable=SC2086  # the pins are words
uv pip install --quiet --python "$venv" --index "$index" \
  --index-strategy unsafe-best-match $torch_pin
# Compile the modules the model adapters and their tests import, once: `uv pip` installs
# without bytecode and PYTHONDONTWRITEBYTECODE may be set, so every test process would
# otherwise compile torch, ultralytics and transformers from source again (~20 s each).
env -u PYTHONDONTWRITEBYTECODE "$venv/bin/python" - <<'PY'
import importlib

for name in (
    "torch", "torchvision", "timm", "scipy.optimize",
    "ultralytics", "ultralytics.models.sam.build", "ultralytics.models.sam.build_sam3",
    "ultralytics.models.sam.predict", "ultralytics.models.yolo.world",
    "transformers", "transformers.models.owlv2.image_processing_pil_owlv2",
    "transformers.models.owlv2.image_processing_owlv2", "transformers.models.clip.modeling_clip",
    "transformers.models.sam3.modeling_sam3", "faster_whisper", "ctranslate2.converters",
):
    importlib.import_module(name)
transformers = importlib.import_module("transformers")
for name in (
    "AutoConfig", "CLIPTokenizer", "Owlv2Config", "Owlv2ForObjectDetection", "Owlv2Processor",
    "Sam2Config", "Sam2Model", "Sam2Processor", "Sam2ImageProcessor",
    "Sam3TrackerConfig", "Sam3TrackerModel", "Sam3TrackerProcessor", "Sam3ImageProcessor",
):
    getattr(transformers, name)
PY
rm -f "$venv"/.model-libs-*
touch "$stamp"
echo "install-model-libs: done in $((SECONDS - started)) s"
