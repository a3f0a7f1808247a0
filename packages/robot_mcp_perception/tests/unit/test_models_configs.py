"""The Hydra YAML of every model adapter instantiates the adapter it names."""

from __future__ import annotations

from pathlib import Path

import pytest
from hydra.utils import get_class, instantiate
from omegaconf import OmegaConf

from robot_mcp_perception.models.base import Grounder, ModelUnavailableError, Segmenter
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.sample_scenes import generate_scenes

CONFIG = Path(__file__).resolve().parents[2] / "config"
ADAPTER_YAMLS = sorted((CONFIG / "grounder").glob("*.yaml")) + sorted(
    (CONFIG / "segmenter").glob("*.yaml")
)


@pytest.mark.parametrize("path", ADAPTER_YAMLS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_every_adapter_yaml_names_a_port_class_and_its_cost_class(path: Path) -> None:
    cfg = OmegaConf.to_container(OmegaConf.load(path))
    assert isinstance(cfg, dict)
    cls = get_class(cfg["_target_"])
    port = Grounder if path.parent.name == "grounder" else Segmenter
    assert issubclass(cls, port)
    assert cfg["cost_class"] == cls.cost_class or path.stem == "fake"


def build(group: str, name: str, **env: str) -> object:
    cfg = OmegaConf.load(CONFIG / group / f"{name}.yaml")
    params = OmegaConf.to_container(cfg, resolve=True)
    assert isinstance(params, dict)
    params.pop("cost_class")
    params.pop("name", None)  # set on the instance by the composition root, like cost_class
    return instantiate(params, _convert_="all")


def test_the_default_segmenters_build_from_their_yaml() -> None:
    assert isinstance(build("segmenter", "grabcut"), GrabCutSegmenter)
    assert isinstance(build("segmenter", "none"), NullSegmenter)


def test_the_annotation_grounder_builds_from_its_yaml(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    generate_scenes(tmp_path, count=1, size=(160, 120))
    monkeypatch.setenv("PERCEPTION_FRAMES_DIR", str(tmp_path))
    grounder = build("grounder", "annotation")
    assert isinstance(grounder, Grounder)
    assert grounder.cost_class == "local"


def test_gemini_without_a_key_refuses_to_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("GEMINI_API_KEY", raising=False)
    with pytest.raises(Exception) as info:
        build("grounder", "gemini_er")
    assert isinstance(info.value, ModelUnavailableError) or isinstance(
        info.value.__cause__, ModelUnavailableError
    )


def test_sam_without_a_checkpoint_refuses_to_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SAM_CHECKPOINT", raising=False)
    with pytest.raises(Exception, match="SAM_CHECKPOINT"):
        build("segmenter", "sam")
