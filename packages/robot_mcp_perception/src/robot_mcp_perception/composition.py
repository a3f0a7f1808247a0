"""Composition root: the only place the grounder, segmenter and frame source are built.

Hydra composes ``config/`` (one group per port, one YAML per adapter with ``_target_`` and
``cost_class``), applies ``PERCEPTION_DEPLOYMENT`` (a preset of ``config/deployment/``) and
``PERCEPTION_CONFIG_OVERRIDES`` (e.g. ``frame_source=folder frame_source.directory=/x
segmenter=none``), Pydantic validates the result (fail fast, one clear message), the secrets
rule is enforced, and the adapters are instantiated.
"""

from __future__ import annotations

import os
import re
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.errors import HydraException, InstantiationException
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException
from pydantic import ValidationError

from robot_mcp_perception.artifacts_auth import artifacts_auth_from_env
from robot_mcp_perception.frames import FolderFrameSource, FrameSource, FrameSourceError
from robot_mcp_perception.logging_setup import configure_logging
from robot_mcp_perception.models.base import Grounder, ModelUnavailableError, Segmenter
from robot_mcp_perception.models.chain import FallbackGrounder
from robot_mcp_perception.pipelines.common import PipelineSettings
from robot_mcp_perception.runtime import Runtime
from robot_mcp_perception.settings import PerceptionSettings, StartupError

OVERRIDES_ENV = "PERCEPTION_CONFIG_OVERRIDES"
DEPLOYMENT_ENV = "PERCEPTION_DEPLOYMENT"
CONFIG_DIR_ENV = "PERCEPTION_CONFIG_DIR"
PORT_GROUPS = ("grounder", "fallback_grounder", "segmenter", "frame_source")
_SECRET_KEY = re.compile(r"(api_key|token|secret|password)", re.IGNORECASE)
_ENV_INTERPOLATION = re.compile(r"^\$\{oc\.env:([A-Za-z_][A-Za-z0-9_]*)(,[^}]*)?\}$")


class ConfigError(StartupError):
    """The composed configuration cannot start the node; the message says how to fix it."""


def default_config_dir() -> Path:
    override = os.environ.get(CONFIG_DIR_ENV)
    if override:
        return Path(override)
    # The package's config/ tree, linked into the package so that wheels carry it too.
    return Path(__file__).parent / "config"


def compose_config(overrides: Sequence[str] = (), config_dir: Path | None = None) -> DictConfig:
    directory = (config_dir or default_config_dir()).resolve()
    if not (directory / "config.yaml").is_file():
        raise ConfigError(f"no config.yaml in {directory} (set {CONFIG_DIR_ENV})")
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=str(directory), version_base="1.3"):
            return compose("config", overrides=list(overrides))
    except (HydraException, OmegaConfBaseException) as error:
        raise ConfigError(
            f"cannot compose the config with overrides {list(overrides)}: {error}"
        ) from error


def validate_config(cfg: DictConfig) -> PerceptionSettings:
    check_secrets(cfg)
    try:
        data = OmegaConf.to_container(cfg, resolve=True)
        return PerceptionSettings.model_validate(data)
    except OmegaConfBaseException as error:
        raise ConfigError(f"the config does not resolve: {error}") from error
    except ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()
        )
        raise ConfigError(f"invalid config: {problems}") from error


def check_secrets(cfg: DictConfig) -> None:
    """Secrets only from the environment, and a selected adapter's secret must be set."""
    for group in PORT_GROUPS:
        block = cfg.get(group)
        if not isinstance(block, DictConfig):
            continue
        raw = OmegaConf.to_container(block, resolve=False)
        assert isinstance(raw, dict)
        for raw_key, value in raw.items():
            key = str(raw_key)
            if not _SECRET_KEY.search(key):
                continue
            match = _ENV_INTERPOLATION.match(str(value)) if isinstance(value, str) else None
            if match is None:
                raise ConfigError(
                    f"{group}.{key} must come from the environment (${{oc.env:NAME}}), "
                    "never from YAML or overrides."
                )
            if not os.environ.get(match.group(1)):
                raise ConfigError(
                    f"{group}.{key} is empty: set {match.group(1)} in the environment (.env) "
                    f"or choose another {group}."
                )


def check_job_timeout(settings: PerceptionSettings, grounder: Grounder) -> None:
    """A run must be allowed to outlast the grounder's own retries, or the node cancels a
    call the grounder would still have retried (and meters requests whose answer it drops)."""
    worst = grounder.worst_case_s
    limit = settings.node.model_timeout_s
    if worst is not None and limit <= worst:
        raise ConfigError(
            f"node.model_timeout_s ({limit:g} s) must exceed the grounder's worst case "
            f"({worst:g} s = timeout_s x attempts + backoff): raise node.model_timeout_s or "
            "lower grounder.timeout_s / grounder.retries"
        )


def instantiate_adapter(block: DictConfig, port: Any, group: str = "") -> Any:
    """Build one adapter; ``cost_class`` and ``name`` from its YAML are set on the instance,
    not passed in (``name``: how results name a grounder, default its class name)."""
    params = OmegaConf.to_container(block, resolve=True)
    assert isinstance(params, dict)
    cost_class = params.pop("cost_class", "local")
    name = str(params.pop("name", "") or "")
    try:
        adapter = instantiate(params, _convert_="all")
    except Exception as error:  # start-up boundary: any adapter constructor failure
        where = f"{group}: " if group else ""
        cause = error.__cause__ if isinstance(error, InstantiationException) else None
        if isinstance(cause, ModelUnavailableError):  # already says what to set
            raise ConfigError(f"{where}{cause}") from error
        raise ConfigError(
            f"{where}cannot build {params.get('_target_')!s}: {cause or error}"
        ) from error
    if not isinstance(adapter, port):
        raise ConfigError(f"{params.get('_target_')!s} is not a {port.__name__}")
    if isinstance(adapter, Grounder | Segmenter):
        adapter.cost_class = cost_class
    if isinstance(adapter, Grounder):
        adapter.name = name or type(adapter).__name__
    return adapter


def build_grounder(cfg: DictConfig, settings: PerceptionSettings) -> Grounder:
    """The ``grounder``, behind a :class:`FallbackGrounder` when ``fallback_grounder`` is set."""
    primary: Grounder = instantiate_adapter(cfg.grounder, Grounder, "grounder")
    if cfg.get("fallback_grounder") is None:
        return primary
    fallback: Grounder = instantiate_adapter(cfg.fallback_grounder, Grounder, "fallback_grounder")
    chain = settings.grounder_chain
    return FallbackGrounder(primary, fallback, chain.retry_after_s, chain.max_retry_after_s)


def build_runtime(overrides: Sequence[str] = (), config_dir: Path | None = None) -> Runtime:
    cfg = compose_config(overrides, config_dir)
    settings = validate_config(cfg)
    configure_logging(settings.logging.json_logs, settings.logging.level)
    artifacts_auth = artifacts_auth_from_env(os.environ)  # before any model is loaded
    frame_source: FrameSource = instantiate_adapter(cfg.frame_source, FrameSource)
    if isinstance(frame_source, FolderFrameSource):
        try:
            frame_source.check()
        except FrameSourceError as error:
            raise ConfigError(str(error)) from error
    grounder = build_grounder(cfg, settings)
    check_job_timeout(settings, grounder)
    segmenter: Segmenter = instantiate_adapter(cfg.segmenter, Segmenter, "segmenter")
    pipeline = settings.pipeline.model_dump()
    return Runtime(
        settings=settings,
        grounder=grounder,
        segmenter=segmenter,
        frame_source=frame_source,
        runner=_pipeline_runner(),
        gate_factory=_gate_factory(),
        overlay_renderer=_overlay_renderer(),
        pipeline_settings=PipelineSettings(**_known(pipeline, PipelineSettings)),
        artifacts_auth=artifacts_auth,
    )


def overrides_from_env(environ: Mapping[str, str] | None = None) -> list[str]:
    env = os.environ if environ is None else environ
    overrides = shlex.split(env.get(OVERRIDES_ENV, ""))
    deployment = env.get(DEPLOYMENT_ENV, "").strip()
    return [f"deployment={deployment}", *overrides] if deployment else overrides


def build_runtime_from_env() -> Runtime:
    return build_runtime(overrides_from_env())


def _known(values: dict[str, Any], cls: type) -> dict[str, Any]:
    fields = getattr(cls, "__dataclass_fields__", {})
    known = {k: v for k, v in values.items() if k in fields}
    if "tile_grid" in known:
        known["tile_grid"] = tuple(known["tile_grid"])
    return known


def _pipeline_runner() -> Any:
    from robot_mcp_perception.pipelines import run_skill

    return run_skill


def _gate_factory() -> Any:
    from robot_mcp_perception.pipelines.watch import FrameDiffGate

    return FrameDiffGate


def _overlay_renderer() -> Any:
    """viz.render_overlay; without it the overlay topic carries the plain frame."""
    try:
        from robot_mcp_perception.viz import render_overlay  # type: ignore[import-not-found,unused-ignore]
    except ImportError:
        return None
    return render_overlay
