"""Composition root: Hydra tree, overrides, deployment presets, validation, secrets rule."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from PIL import Image as PILImage

from robot_mcp_perception.composition import (
    ConfigError,
    build_runtime,
    check_secrets,
    compose_config,
    default_config_dir,
    overrides_from_env,
    validate_config,
)
from robot_mcp_perception.frames import FolderFrameSource
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter


@pytest.fixture
def config_dir(tmp_path: Path) -> Path:
    """The package's config tree plus test adapters (fake grounder, null segmenter)."""
    target = tmp_path / "config"
    shutil.copytree(default_config_dir(), target)
    (target / "grounder").mkdir(exist_ok=True)
    (target / "segmenter").mkdir(exist_ok=True)
    (target / "grounder" / "test_fake.yaml").write_text(
        "_target_: robot_mcp_perception.models.fakes.FakeGrounder\ncost_class: cloud\n"
    )
    (target / "grounder" / "test_keyed.yaml").write_text(
        "_target_: robot_mcp_perception.models.fakes.FakeGrounder\ncost_class: cloud\n"
        "api_key: ${oc.env:TEST_PERCEPTION_KEY,''}\n"
    )
    (target / "grounder" / "test_literal.yaml").write_text(
        "_target_: robot_mcp_perception.models.fakes.FakeGrounder\napi_key: sk-123\n"
    )
    (target / "segmenter" / "test_none.yaml").write_text(
        "_target_: robot_mcp_perception.models.null.NullSegmenter\ncost_class: local\n"
    )
    (target / "deployment" / "test_preset.yaml").write_text(
        "# @package _global_\n"
        "node:\n  processing_frequency: 3.0\n"
        "cost:\n  max_cloud_calls_per_min: 7\n"
    )
    return target


@pytest.fixture
def frames_dir(tmp_path: Path) -> Path:
    directory = tmp_path / "frames"
    directory.mkdir()
    PILImage.new("RGB", (32, 24)).save(directory / "f.png")
    return directory


def _overrides(frames_dir: Path, *extra: str) -> list[str]:
    return [
        "grounder=test_fake",
        "segmenter=test_none",
        "frame_source=folder",
        f"frame_source.directory={frames_dir}",
        *extra,
    ]


def test_adapters_are_built_from_the_selected_yaml_with_their_cost_class(
    config_dir: Path, frames_dir: Path
) -> None:
    runtime = build_runtime(_overrides(frames_dir), config_dir)

    assert isinstance(runtime.grounder, FakeGrounder)
    assert runtime.grounder.cost_class == "cloud"
    assert isinstance(runtime.segmenter, NullSegmenter)
    assert runtime.segmenter.cost_class == "local"
    assert isinstance(runtime.frame_source, FolderFrameSource)
    assert runtime.frame_source.directory == frames_dir
    assert runtime.settings.node.default_skills[0]["name"] == "scene"
    assert runtime.gate_factory is not None
    assert runtime.runner is not None


def test_a_deployment_preset_overrides_the_root_config(config_dir: Path, frames_dir: Path) -> None:
    runtime = build_runtime(["deployment=test_preset", *_overrides(frames_dir)], config_dir)

    assert runtime.settings.node.processing_frequency == 3.0
    assert runtime.settings.cost.max_cloud_calls_per_min == 7


def test_invalid_values_fail_fast_with_the_offending_key(
    config_dir: Path, frames_dir: Path
) -> None:
    with pytest.raises(ConfigError, match=r"node\.max_in_flight"):
        build_runtime(_overrides(frames_dir, "node.max_in_flight=0"), config_dir)


def test_unknown_adapter_is_a_clear_error(config_dir: Path, frames_dir: Path) -> None:
    with pytest.raises(ConfigError, match="cannot compose"):
        build_runtime(_overrides(frames_dir, "segmenter=does_not_exist"), config_dir)


def test_missing_frame_folder_says_how_to_generate_it(config_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="sample_scenes"):
        build_runtime(_overrides(tmp_path / "missing"), config_dir)


def test_secrets_must_come_from_the_environment(
    config_dir: Path, frames_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    literal = compose_config(_overrides(frames_dir, "grounder=test_literal"), config_dir)
    with pytest.raises(ConfigError, match="must come from the environment"):
        check_secrets(literal)

    keyed = compose_config(_overrides(frames_dir, "grounder=test_keyed"), config_dir)
    monkeypatch.delenv("TEST_PERCEPTION_KEY", raising=False)
    with pytest.raises(ConfigError, match="TEST_PERCEPTION_KEY"):
        validate_config(keyed)
    monkeypatch.setenv("TEST_PERCEPTION_KEY", "secret-value")
    check_secrets(keyed)


def test_overrides_and_deployment_come_from_the_environment() -> None:
    env = {
        "PERCEPTION_CONFIG_OVERRIDES": (
            "frame_source=folder frame_source.directory=/x segmenter=none"
        ),
        "PERCEPTION_DEPLOYMENT": "robot",
    }

    assert overrides_from_env(env) == [
        "deployment=robot",
        "frame_source=folder",
        "frame_source.directory=/x",
        "segmenter=none",
    ]
    assert overrides_from_env({}) == []


def test_the_annotation_grounder_reads_the_folder_the_frames_come_from(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from omegaconf import OmegaConf

    monkeypatch.delenv("PERCEPTION_ANNOTATIONS_DIR", raising=False)
    monkeypatch.setenv("PERCEPTION_FRAMES_DIR", "/frames/default")

    def grounder_directory(*overrides: str) -> str:
        block = OmegaConf.to_container(compose_config(overrides).grounder, resolve=True)
        assert isinstance(block, dict)
        return str(block["directory"])

    assert grounder_directory() == "/frames/default"
    assert grounder_directory("frame_source.directory=/frames/other") == "/frames/other"
    assert grounder_directory("frame_source=ros") == "/frames/default"
    monkeypatch.setenv("PERCEPTION_ANNOTATIONS_DIR", "/annotations")
    assert grounder_directory("frame_source.directory=/frames/other") == "/annotations"


def test_the_shipped_gemini_config_fits_in_the_node_job_timeout(
    config_dir: Path, frames_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GEMINI_API_KEY", "test-key")
    overrides = ["grounder=gemini_er", *_overrides(frames_dir)[1:]]
    runtime = build_runtime(overrides, config_dir)

    worst = runtime.grounder.worst_case_s
    assert worst is not None
    assert runtime.settings.node.model_timeout_s > worst


def test_a_job_timeout_shorter_than_the_grounders_retries_refuses_to_start(
    config_dir: Path, frames_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GEMINI_API_KEY", "test-key")
    overrides = ["grounder=gemini_er", *_overrides(frames_dir)[1:], "grounder.timeout_s=30"]
    with pytest.raises(ConfigError, match=r"node\.model_timeout_s .* grounder's worst case"):
        build_runtime(overrides, config_dir)


@pytest.mark.parametrize("segmenter", ["sam", "hf_sam"])
def test_a_segmenter_without_its_weights_refuses_in_one_line_naming_the_setting(
    config_dir: Path, frames_dir: Path, monkeypatch: pytest.MonkeyPatch, segmenter: str
) -> None:
    monkeypatch.delenv("SAM_CHECKPOINT", raising=False)
    overrides = [*_overrides(frames_dir)[:1], f"segmenter={segmenter}", *_overrides(frames_dir)[2:]]
    with pytest.raises(ConfigError) as refused:
        build_runtime(overrides, config_dir)
    message = str(refused.value)
    assert message.startswith("segmenter: no ")  # the adapter's sentence, not Hydra's wrapper
    assert "SAM_CHECKPOINT" in message
    assert "\n" not in message


def test_a_multi_line_cause_becomes_one_line() -> None:
    assert str(ConfigError("cannot compose:\nError in call\nfull_key: x")) == (
        "cannot compose: Error in call full_key: x"
    )
